#pragma once
// What tests inject into `rutd run` (add_run_command): faults at the lowest I/O calls and a stand-in for
// the CAN socket. The rutd executable passes none (main.cpp); only the test program
// tests/fault/rutd_faults.cpp does, so no configuration, option or environment variable of the daemon
// can switch a fault on.
#include <functional>
#include <memory>
#include <string>

#include "can/socketcan_bus.hpp"
#include "can/vehicle_speed_receiver.hpp"
#include "core/io_faults.hpp"

namespace rutd {

struct RunInjection {
  // Handed to every driver the daemon builds (sources, CAN bus, recorder). Not owned; outlives the run.
  IoFaults* faults = nullptr;
  // Opens the bus named by sinks.socketcan instead of SocketCanBus(interface, faults).
  std::function<std::unique_ptr<SocketCanBus>(const std::string& interface)> open_bus;
  // Opens the speed receiver named by trafficability.speed.socketcan instead of VehicleSpeedReceiver(...).
  std::function<std::unique_ptr<VehicleSpeedReceiver>(const std::string& interface, const VehicleSpeedConfig& config,
                                                      std::ostream* log)>
      open_speed;
};

}  // namespace rutd
