// rutd cameras: what a person wiring a bench needs to see. Lists every camera Aravis discovers (transport,
// vendor, model, serial, address, id) and, for the cameras asked for (--camera, or the left and right of
// --config), the features rutd sets with their current values. Opening a camera for its features takes
// control of it for a moment: run it while rutd itself is not streaming from that camera.
#include <iostream>
#include <memory>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "camera/camera_error.hpp"
#include "camera/camera_list.hpp"
#include "core/input_error.hpp"
#include "daemon/commands.hpp"
#include "daemon/config.hpp"

namespace rutd {
namespace {

struct CamerasOptions {
  std::vector<std::string> cameras;
  std::string config;
};

void print_listing(const std::vector<CameraListing>& found) {
  if (found.empty()) {
    std::cout << "no cameras found (GigE: same subnet and a route for broadcast; USB3 Vision: the udev rule in "
                 "systemd/ gives access)\n";
    return;
  }
  std::cout << fmt::format("{:<11} {:<16} {:<20} {:<16} {:<18} {}\n", "transport", "vendor", "model", "serial",
                           "address", "id");
  for (const auto& c : found)
    std::cout << fmt::format("{:<11} {:<16} {:<20} {:<16} {:<18} {}\n", c.protocol, c.vendor, c.model, c.serial,
                             c.address, c.id);
}

// Returns false when the camera cannot be found or opened (said on stderr).
bool print_features(const std::vector<CameraListing>& found, const std::string& selector) {
  const auto listing = find_camera(found, selector);
  if (!listing) {
    std::cerr << "rutd: error: camera '" << selector << "': not found (give an id, serial or address listed above)\n";
    return false;
  }
  try {
    const auto features = read_camera_features(*listing, "camera " + selector);
    std::cout << fmt::format("\n{} ({} {} {}, {}):\n", selector, listing->vendor, listing->model, listing->serial,
                             listing->address);
    for (const auto& [name, value] : features) std::cout << fmt::format("  {:<28} {}\n", name, value);
  } catch (const CameraError& e) {
    std::cerr << "rutd: error: " << e.what() << '\n';
    return false;
  }
  return true;
}

int run_cameras(const CamerasOptions& o) {
  std::vector<std::string> selectors = o.cameras;
  if (!o.config.empty()) {
    const RutdConfig c = load_config(o.config);  // throws InputError naming the file and key
    for (const std::string* s : {&c.aravis.left, &c.aravis.right})
      if (!s->empty()) selectors.push_back(*s);
  }
  const std::vector<CameraListing> found = list_cameras();
  print_listing(found);
  bool ok = true;
  for (const auto& s : selectors) ok = print_features(found, s) && ok;
  std::cout.flush();
  return ok ? 0 : 1;
}

}  // namespace

void add_cameras_command(CLI::App& app, int& exit_code) {
  auto o = std::make_shared<CamerasOptions>();
  CLI::App* cmd = app.add_subcommand("cameras",
                                     "List the GigE Vision and USB3 Vision cameras found, and the features "
                                     "rutd uses of the ones named");
  cmd->add_option("--camera", o->cameras, "Also print the features of this camera (id, serial or address); repeatable");
  cmd->add_option("--config", o->config, "Also print the features of this configuration's left and right cameras");
  cmd->callback([o, &exit_code] { exit_code = run_cameras(*o); });
}

}  // namespace rutd
