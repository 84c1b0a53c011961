# The Debian package, rutd_MAJOR.MINOR.PATCH-REVISION_ARCH.deb, made by CPack's DEB generator from what
# `cmake --install` installs (scripts/package builds and checks it; the systemd boot test installs it):
# the program, the unit, udev, sysctl, tmpfiles and sysusers files, the DBC, the documentation, the
# vehicle configuration /etc/rutd/rutd.yaml as a conffile, and maintainer scripts that do what Debian's
# service packages do (postinst, prerm, postrm beside this file). Run-time dependencies are computed from
# the program by dpkg-shlibdeps; only what the maintainer scripts call is listed here.
include(GNUInstallDirs)

# The Maintainer: field and the changelog's signature: RUTD_PACKAGE_MAINTAINER, else Debian's DEBFULLNAME
# and DEBEMAIL, else the git identity of the checkout (who builds the package answers for it). Without
# any, an address that says so (.invalid, RFC 2606): scripts/package refuses to make a package with it,
# test packages of a development build may carry it.
set(RUTD_PACKAGE_MAINTAINER "" CACHE STRING "Maintainer of the package, 'Name <email>' (default: DEBFULLNAME/DEBEMAIL, git user)")
set(rutd_maintainer "${RUTD_PACKAGE_MAINTAINER}")
if(rutd_maintainer STREQUAL "" AND NOT "$ENV{DEBFULLNAME}" STREQUAL "" AND NOT "$ENV{DEBEMAIL}" STREQUAL "")
  set(rutd_maintainer "$ENV{DEBFULLNAME} <$ENV{DEBEMAIL}>")
endif()
find_program(RUTD_GIT_PROGRAM git)
if(rutd_maintainer STREQUAL "" AND RUTD_GIT_PROGRAM)
  execute_process(COMMAND ${RUTD_GIT_PROGRAM} -C ${PROJECT_SOURCE_DIR} config user.name
                  OUTPUT_VARIABLE git_name OUTPUT_STRIP_TRAILING_WHITESPACE ERROR_QUIET)
  execute_process(COMMAND ${RUTD_GIT_PROGRAM} -C ${PROJECT_SOURCE_DIR} config user.email
                  OUTPUT_VARIABLE git_email OUTPUT_STRIP_TRAILING_WHITESPACE ERROR_QUIET)
  if(NOT git_name STREQUAL "" AND NOT git_email STREQUAL "")
    set(rutd_maintainer "${git_name} <${git_email}>")
  endif()
endif()
if(rutd_maintainer STREQUAL "")
  set(rutd_maintainer "nobody set <maintainer@rutd.invalid>")  # scripts/package looks for "nobody set"
  message(STATUS "Debian package: no maintainer (RUTD_PACKAGE_MAINTAINER, DEBFULLNAME/DEBEMAIL, git user): ${rutd_maintainer}")
endif()

# The changelog entry of this version, dated like the commit built (SOURCE_DATE_EPOCH when set), so that
# two builds of one commit give the same file. Debian's binary packages carry it as changelog.Debian.gz.
set(rutd_changelog_date "")
if(DEFINED ENV{SOURCE_DATE_EPOCH})
  execute_process(COMMAND date -u -R -d @$ENV{SOURCE_DATE_EPOCH} OUTPUT_VARIABLE rutd_changelog_date
                  OUTPUT_STRIP_TRAILING_WHITESPACE)
elseif(RUTD_GIT_PROGRAM)
  execute_process(COMMAND ${RUTD_GIT_PROGRAM} -C ${PROJECT_SOURCE_DIR} log -1 --format=%cD
                  OUTPUT_VARIABLE rutd_changelog_date OUTPUT_STRIP_TRAILING_WHITESPACE ERROR_QUIET)
endif()
if(rutd_changelog_date STREQUAL "")
  execute_process(COMMAND date -u -R OUTPUT_VARIABLE rutd_changelog_date OUTPUT_STRIP_TRAILING_WHITESPACE)
endif()
set(rutd_package_dir ${PROJECT_BINARY_DIR}/packaging)
file(CONFIGURE OUTPUT ${rutd_package_dir}/changelog.Debian @ONLY CONTENT
"rutd (@RUTD_PACKAGE_VERSION@) bookworm; urgency=medium

  * rutd @PROJECT_VERSION@, package revision @RUTD_PACKAGE_REVISION@. The changes are the project's git
    history; `rutd --version` names the commit this package was built from.

 -- @rutd_maintainer@  @rutd_changelog_date@
")
# The copyright file's years: those of the first and the last commit (the build's year without git).
string(TIMESTAMP rutd_copyright_years "%Y" UTC)
if(RUTD_GIT_PROGRAM)
  execute_process(COMMAND ${RUTD_GIT_PROGRAM} -C ${PROJECT_SOURCE_DIR} log --format=%cd --date=format:%Y
                  OUTPUT_VARIABLE years OUTPUT_STRIP_TRAILING_WHITESPACE ERROR_QUIET)
  if(years MATCHES "^([0-9]+)")
    set(last ${CMAKE_MATCH_1})
    string(REGEX MATCH "([0-9]+)$" first "${years}")
    set(rutd_copyright_years ${first})
    if(NOT first STREQUAL last)
      set(rutd_copyright_years ${first}-${last})
    endif()
  endif()
endif()
configure_file(${CMAKE_CURRENT_LIST_DIR}/copyright.in ${rutd_package_dir}/copyright @ONLY)

# Compressed as Debian's tools do (gzip -9n: no name, no time stamp): the changelog and the manual page.
foreach(pair "${rutd_package_dir}/changelog.Debian|${rutd_package_dir}/changelog.Debian.gz"
             "${PROJECT_SOURCE_DIR}/docs/rutd.1|${rutd_package_dir}/rutd.1.gz")
  string(REPLACE "|" ";" pair "${pair}")
  list(GET pair 0 from)
  list(GET pair 1 to)
  execute_process(COMMAND gzip -9nc ${from} OUTPUT_FILE ${to} RESULT_VARIABLE status)
  if(NOT status EQUAL 0)
    message(FATAL_ERROR "packaging/deb.cmake: gzip -9n ${from} failed")
  endif()
endforeach()
set_property(DIRECTORY APPEND PROPERTY CMAKE_CONFIGURE_DEPENDS ${PROJECT_SOURCE_DIR}/docs/rutd.1)
install(FILES ${rutd_package_dir}/changelog.Debian.gz ${rutd_package_dir}/copyright DESTINATION ${CMAKE_INSTALL_DOCDIR})
install(FILES ${rutd_package_dir}/rutd.1.gz DESTINATION ${CMAKE_INSTALL_MANDIR}/man1)
install(FILES ${CMAKE_CURRENT_LIST_DIR}/lintian-overrides DESTINATION ${CMAKE_INSTALL_DATADIR}/lintian/overrides
        RENAME rutd)

file(WRITE ${rutd_package_dir}/conffiles "/etc/rutd/rutd.yaml\n")

set(CPACK_GENERATOR DEB)
set(CPACK_PACKAGE_NAME rutd)
set(CPACK_PACKAGE_VERSION ${PROJECT_VERSION})
set(CPACK_DEBIAN_PACKAGE_RELEASE ${RUTD_PACKAGE_REVISION})
set(CPACK_DEBIAN_FILE_NAME DEB-DEFAULT)  # rutd_0.1.0-1_amd64.deb
set(CPACK_PACKAGE_CONTACT "${rutd_maintainer}")
set(CPACK_DEBIAN_PACKAGE_MAINTAINER "${rutd_maintainer}")
set(CPACK_DEBIAN_PACKAGE_SECTION science)
set(CPACK_DEBIAN_PACKAGE_PRIORITY optional)
set(CPACK_PACKAGE_DESCRIPTION_SUMMARY "tyre rut depth from stereo cameras, in real time, on the CAN bus")
set(CPACK_DEBIAN_PACKAGE_DESCRIPTION "rutd measures the rut a tyre leaves in sand, mud, snow or grass from two
calibrated machine-vision cameras (GigE Vision or USB3 Vision, through
Aravis) mounted behind the tyre, and publishes rut depth, width, pile
heights, cross-section area and ground slope on the vehicle CAN network
(J1939 or 11-bit identifiers, described by /usr/share/rutd/rutd.dbc).
.
It runs as a systemd service that starts at boot; the same program records
camera pairs, replays recordings on a bench, calibrates the cameras and
renders synthetic scenes with known ground truth.")
# Cross-built (scripts/package --arch, packaging/cross-ARCH.cmake): the target's architecture, not the one
# CPack would ask this machine's dpkg for.
if(CMAKE_CROSSCOMPILING AND RUTD_DEB_ARCHITECTURE)
  set(CPACK_DEBIAN_PACKAGE_ARCHITECTURE ${RUTD_DEB_ARCHITECTURE})
endif()
set(CPACK_DEBIAN_PACKAGE_SHLIBDEPS ON)
# What the maintainer scripts run besides dpkg's own tools (deb-systemd-helper and deb-systemd-invoke are
# in init-system-helpers, which is essential): systemd-sysusers creates the service's user.
set(CPACK_DEBIAN_PACKAGE_DEPENDS "systemd | systemd-standalone-sysusers | systemd-sysusers")
set(CPACK_DEBIAN_PACKAGE_SUGGESTS "can-utils, aravis-tools")
set(CPACK_DEBIAN_PACKAGE_CONTROL_EXTRA ${CMAKE_CURRENT_LIST_DIR}/postinst ${CMAKE_CURRENT_LIST_DIR}/prerm
    ${CMAKE_CURRENT_LIST_DIR}/postrm ${rutd_package_dir}/conffiles)
set(CPACK_DEBIAN_PACKAGE_CONTROL_STRICT_PERMISSION ON)
set(CPACK_DEBIAN_COMPRESSION_TYPE xz)
set(CPACK_STRIP_FILES ON)
# Installed with DESTDIR under /usr, as a packager does: the absolute destinations (/etc/rutd, /lib/...)
# land in the package as they are, and the unit names /usr/bin/rutd.
set(CPACK_SET_DESTDIR ON)
set(CPACK_PACKAGING_INSTALL_PREFIX /usr)
set(CPACK_INSTALL_PREFIX /usr)
set(CPACK_OUTPUT_FILE_PREFIX ${PROJECT_BINARY_DIR}/package)
include(CPack)
