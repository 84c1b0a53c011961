# The configuration `cmake --install` puts in /etc/rutd for a vehicle: config/rutd.yaml (the bench
# default compiled into rutd, where CAN frames go to stdout in candump format) with three values
# changed, so that the journal a vehicle PC keeps on flash gets summaries, not a line per CAN frame, and
# so that nothing but real cameras is ever measured and published on the vehicle bus:
#   source.type: aravis          the cameras (source.aravis.left/right must be set before rutd starts)
#   calibration: /etc/rutd/calibration.yaml   where `rutd calibrate --out` puts the rig's calibration
#   sinks.socketcan: can0   frames go to the CAN interface (systemd/80-rutd-can0.network brings it up)
#   sinks.candump: ""       no candump log; on stdout, under systemd, every frame would be a journal line
#   logging.stats_period_s: 60   one pipeline summary a minute (state changes are logged when they happen)
# Every other key keeps the default and its comment. Generated at configure time into
# <build>/config/rutd.yaml; a default line that no longer matches fails the configuration.
file(READ ${PROJECT_SOURCE_DIR}/config/rutd.yaml rutd_vehicle_config)
foreach(change
    "  type: synthetic            |  type: aravis               "
    "calibration: \"\"              |calibration: /etc/rutd/calibration.yaml  "
    "  socketcan: \"\"              |  socketcan: can0            "
    "  candump: \"-\"               |  candump: \"\"                "
    "  stats_period_s: 10|  stats_period_s: 60")
  string(REPLACE "|" ";" change "${change}")
  list(GET change 0 from)
  list(GET change 1 to)
  string(FIND "${rutd_vehicle_config}" "\n${from}" at)
  if(at EQUAL -1)
    message(FATAL_ERROR "config/vehicle_config.cmake: config/rutd.yaml has no line starting '${from}'")
  endif()
  string(REPLACE "\n${from}" "\n${to}" rutd_vehicle_config "${rutd_vehicle_config}")
endforeach()
string(REPLACE "# rutd configuration. `rutd run --config FILE`; without --config rutd runs this file as compiled in.\n"
       "# rutd configuration for a vehicle, as installed: the two cameras (set source.aravis.left/right), CAN frames\n# to can0, a summary a minute in the journal.\n# `rutd run` without --config runs the bench default instead (frames on stdout in candump format).\n"
       rutd_vehicle_config "${rutd_vehicle_config}")
file(WRITE ${PROJECT_BINARY_DIR}/config/rutd.yaml "${rutd_vehicle_config}")
set_property(DIRECTORY APPEND PROPERTY CMAKE_CONFIGURE_DEPENDS ${PROJECT_SOURCE_DIR}/config/rutd.yaml)
install(FILES ${PROJECT_BINARY_DIR}/config/rutd.yaml DESTINATION /etc/rutd)
