// USB3 Vision hot-plug: the device classification on descriptor sets written out by hand (a USB3 Vision
// camera, a mass-storage stick, a UVC webcam and near misses), both as the raw bytes a device sends and
// as libusb's parsed structures; the arrival counter's waiting; and the monitor's start, stop and
// fallback where the platform gives no hot-plug.
#include <libusb.h>

#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <stop_token>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "skip_policy.hpp"
#include "usb_hotplug.hpp"

namespace rutd {
namespace {

using Bytes = std::vector<std::uint8_t>;
using std::chrono::milliseconds;

void append(Bytes& out, const Bytes& more) { out.insert(out.end(), more.begin(), more.end()); }

// A configuration descriptor followed by `body`, with wTotalLength filled in.
Bytes configuration(std::uint8_t interfaces, const Bytes& body) {
  Bytes out{0x09, 0x02, 0x00, 0x00, interfaces, 0x01, 0x00, 0x80, 0x70};
  append(out, body);
  out[2] = static_cast<std::uint8_t>(out.size() & 0xFF);
  out[3] = static_cast<std::uint8_t>(out.size() >> 8);
  return out;
}

Bytes interface(std::uint8_t number, std::uint8_t alt, std::uint8_t endpoints, std::uint8_t cls, std::uint8_t subclass,
                std::uint8_t protocol) {
  return {0x09, 0x04, number, alt, endpoints, cls, subclass, protocol, 0x00};
}

Bytes association(std::uint8_t first, std::uint8_t count, std::uint8_t cls, std::uint8_t subclass,
                  std::uint8_t protocol) {
  return {0x08, 0x0B, first, count, cls, subclass, protocol, 0x00};
}

Bytes bulk_endpoint(std::uint8_t address) { return {0x07, 0x05, address, 0x02, 0x00, 0x04, 0x00}; }
const Bytes kSuperSpeedCompanion{0x06, 0x30, 0x00, 0x00, 0x00, 0x00};

// USB3 Vision device info descriptor (class-specific, type 0x24): 20 bytes of capability data.
Bytes u3v_device_info() {
  Bytes d(20, 0x00);
  d[0] = 20;
  d[1] = 0x24;
  d[2] = 0x01;
  return d;
}

// A USB3 Vision camera: IAD 0xEF/0x05/0x00 over three interfaces, control 0xEF/0x05/0x00 (bulk in and
// out), event 0xEF/0x05/0x01 (bulk in), streaming 0xEF/0x05/0x02 (bulk in).
Bytes u3v_camera() {
  Bytes body = association(0, 3, 0xEF, 0x05, 0x00);
  append(body, interface(0, 0, 2, 0xEF, 0x05, 0x00));
  append(body, u3v_device_info());
  append(body, bulk_endpoint(0x01));
  append(body, kSuperSpeedCompanion);
  append(body, bulk_endpoint(0x81));
  append(body, kSuperSpeedCompanion);
  append(body, interface(1, 0, 1, 0xEF, 0x05, 0x01));
  append(body, bulk_endpoint(0x82));
  append(body, kSuperSpeedCompanion);
  append(body, interface(2, 0, 1, 0xEF, 0x05, 0x02));
  append(body, bulk_endpoint(0x83));
  append(body, kSuperSpeedCompanion);
  return configuration(3, body);
}

// A USB mass-storage stick: SCSI transparent command set, bulk-only transport (0x08/0x06/0x50).
Bytes mass_storage() {
  Bytes body = interface(0, 0, 2, 0x08, 0x06, 0x50);
  append(body, bulk_endpoint(0x81));
  append(body, bulk_endpoint(0x02));
  return configuration(1, body);
}

// A UVC webcam with a microphone: video IAD 0x0E/0x03, video control and streaming interfaces (streaming
// with a zero-bandwidth and an isochronous alternate setting), audio control and streaming interfaces.
Bytes uvc_webcam() {
  Bytes body = association(0, 2, 0x0E, 0x03, 0x00);
  append(body, interface(0, 0, 1, 0x0E, 0x01, 0x00));
  append(body, {0x0D, 0x24, 0x01, 0x00, 0x01, 0x4D, 0x00, 0x80, 0xC3, 0xC9, 0x01, 0x01, 0x01});
  append(body, {0x07, 0x05, 0x83, 0x03, 0x10, 0x00, 0x06});
  append(body, interface(1, 0, 0, 0x0E, 0x02, 0x00));
  append(body, {0x0E, 0x24, 0x01, 0x01, 0x00, 0x00, 0x81, 0x00, 0x02, 0x00, 0x00, 0x00, 0x01, 0x00});
  append(body, interface(1, 1, 1, 0x0E, 0x02, 0x00));
  append(body, {0x07, 0x05, 0x81, 0x05, 0x00, 0x14, 0x01});
  append(body, association(2, 2, 0x01, 0x02, 0x00));
  append(body, interface(2, 0, 0, 0x01, 0x01, 0x00));
  append(body, interface(3, 0, 0, 0x01, 0x02, 0x00));
  return configuration(4, body);
}

TEST(Usb3VisionClass, OnlyTheCameraIsUsb3VisionFromRawDescriptors) {
  EXPECT_TRUE(is_usb3_vision_descriptors(u3v_camera()));
  EXPECT_FALSE(is_usb3_vision_descriptors(mass_storage()));
  EXPECT_FALSE(is_usb3_vision_descriptors(uvc_webcam()));
}

TEST(Usb3VisionClass, NearMissesAreNotUsb3Vision) {
  // Event and streaming interfaces without the control interface.
  Bytes body = interface(0, 0, 1, 0xEF, 0x05, 0x01);
  append(body, bulk_endpoint(0x81));
  append(body, interface(1, 0, 1, 0xEF, 0x05, 0x02));
  append(body, bulk_endpoint(0x82));
  EXPECT_FALSE(is_usb3_vision_descriptors(configuration(2, body)));

  // Another miscellaneous-class function (RNDIS: 0xEF/0x04/0x01) in an IAD and an interface.
  body = association(0, 2, 0xEF, 0x04, 0x01);
  append(body, interface(0, 0, 1, 0xEF, 0x04, 0x01));
  append(body, interface(1, 0, 2, 0x0A, 0x00, 0x00));
  EXPECT_FALSE(is_usb3_vision_descriptors(configuration(2, body)));

  // The class triple inside a class-specific descriptor (type 0x24) at an interface's offsets.
  body = interface(0, 0, 0, 0xFF, 0x00, 0x00);
  append(body, {0x09, 0x24, 0x00, 0x00, 0x00, 0xEF, 0x05, 0x00, 0x00});
  EXPECT_FALSE(is_usb3_vision_descriptors(configuration(1, body)));
}

TEST(Usb3VisionClass, ControlInterfaceOrAssociationAloneIsEnough) {
  EXPECT_TRUE(is_usb3_vision_descriptors(configuration(1, interface(0, 0, 2, 0xEF, 0x05, 0x00))));
  // The association names the function even where the interfaces are vendor-specific.
  Bytes body = association(0, 1, 0xEF, 0x05, 0x00);
  append(body, interface(0, 0, 2, 0xFF, 0xFF, 0xFF));
  EXPECT_TRUE(is_usb3_vision_descriptors(configuration(1, body)));
  // A control interface in an alternate setting counts too.
  body = interface(0, 0, 0, 0xFF, 0x00, 0x00);
  append(body, interface(0, 1, 2, 0xEF, 0x05, 0x00));
  EXPECT_TRUE(is_usb3_vision_descriptors(configuration(1, body)));
}

TEST(Usb3VisionClass, MalformedDescriptorsStopTheWalk) {
  const Bytes camera = u3v_camera();
  // Cut inside the IAD (configuration 9 bytes + 5 of the IAD's 8): nothing USB3 Vision is whole. With
  // the whole IAD the function is recognised.
  EXPECT_FALSE(is_usb3_vision_descriptors(std::span(camera).first(9 + 5)));
  EXPECT_TRUE(is_usb3_vision_descriptors(std::span(camera).first(9 + 8)));
  EXPECT_FALSE(is_usb3_vision_descriptors({}));

  Bytes zero_length = configuration(1, {0x00, 0x04});  // bLength 0 would loop forever if trusted
  append(zero_length, interface(0, 0, 2, 0xEF, 0x05, 0x00));
  EXPECT_FALSE(is_usb3_vision_descriptors(zero_length));

  Bytes too_long = configuration(1, {0xF0, 0x24, 0x00});  // claims 240 bytes, has 3
  append(too_long, interface(0, 0, 2, 0xEF, 0x05, 0x00));
  EXPECT_FALSE(is_usb3_vision_descriptors(too_long));

  // A short interface descriptor (bLength 7) is not read past its end.
  EXPECT_FALSE(is_usb3_vision_descriptors(configuration(1, {0x07, 0x04, 0x00, 0x00, 0x00, 0xEF, 0x05})));
}

// libusb's parsed form, built by hand the way libusb files a configuration: interface descriptors and
// their endpoints become structures; every other descriptor stays as `extra` bytes of the configuration
// (before the first interface), the interface or the endpoint it follows.
struct ParsedConfig {
  std::vector<std::vector<libusb_interface_descriptor>> alts;  // per interface
  std::vector<libusb_interface> interfaces;
  Bytes config_extra;
  Bytes endpoint_extra;
  libusb_config_descriptor config{};

  static libusb_interface_descriptor alt(std::uint8_t number, std::uint8_t setting, std::uint8_t cls,
                                         std::uint8_t subclass, std::uint8_t protocol) {
    libusb_interface_descriptor d{};
    d.bLength = 9;
    d.bDescriptorType = LIBUSB_DT_INTERFACE;
    d.bInterfaceNumber = number;
    d.bAlternateSetting = setting;
    d.bInterfaceClass = cls;
    d.bInterfaceSubClass = subclass;
    d.bInterfaceProtocol = protocol;
    return d;
  }

  // Builds the pointers once every vector is final.
  const libusb_config_descriptor& finish() {
    interfaces.clear();
    for (auto& a : alts) {
      libusb_interface i{};
      i.altsetting = a.data();
      i.num_altsetting = static_cast<int>(a.size());
      interfaces.push_back(i);
    }
    config.bLength = 9;
    config.bDescriptorType = LIBUSB_DT_CONFIG;
    config.bNumInterfaces = static_cast<std::uint8_t>(interfaces.size());
    config.interface = interfaces.data();
    config.extra = config_extra.empty() ? nullptr : config_extra.data();
    config.extra_length = static_cast<int>(config_extra.size());
    return config;
  }
};

TEST(Usb3VisionClass, OnlyTheCameraIsUsb3VisionFromLibusbStructures) {
  ParsedConfig camera;
  camera.config_extra = association(0, 3, 0xEF, 0x05, 0x00);
  camera.alts = {{ParsedConfig::alt(0, 0, 0xEF, 0x05, 0x00)},
                 {ParsedConfig::alt(1, 0, 0xEF, 0x05, 0x01)},
                 {ParsedConfig::alt(2, 0, 0xEF, 0x05, 0x02)}};
  EXPECT_TRUE(is_usb3_vision_config(camera.finish()));

  ParsedConfig stick;
  stick.alts = {{ParsedConfig::alt(0, 0, 0x08, 0x06, 0x50)}};
  EXPECT_FALSE(is_usb3_vision_config(stick.finish()));

  ParsedConfig webcam;
  webcam.config_extra = association(0, 2, 0x0E, 0x03, 0x00);
  webcam.alts = {{ParsedConfig::alt(0, 0, 0x0E, 0x01, 0x00)},
                 {ParsedConfig::alt(1, 0, 0x0E, 0x02, 0x00), ParsedConfig::alt(1, 1, 0x0E, 0x02, 0x00)},
                 {ParsedConfig::alt(2, 0, 0x01, 0x01, 0x00)},
                 {ParsedConfig::alt(3, 0, 0x01, 0x02, 0x00)}};
  EXPECT_FALSE(is_usb3_vision_config(webcam.finish()));

  ParsedConfig no_control;
  no_control.alts = {{ParsedConfig::alt(0, 0, 0xEF, 0x05, 0x01)}, {ParsedConfig::alt(1, 0, 0xEF, 0x05, 0x02)}};
  EXPECT_FALSE(is_usb3_vision_config(no_control.finish()));

  ParsedConfig empty;
  EXPECT_FALSE(is_usb3_vision_config(empty.finish()));
}

TEST(Usb3VisionClass, AssociationInAnEndpointsExtraBytesCounts) {
  // A vendor interface 0 with one endpoint, then the USB3 Vision IAD for interfaces 1..: libusb files
  // the IAD as the extra bytes of interface 0's endpoint. The interfaces themselves are vendor-specific
  // here, so only the IAD can say USB3 Vision.
  ParsedConfig parsed;
  parsed.endpoint_extra = association(1, 1, 0xEF, 0x05, 0x00);
  parsed.alts = {{ParsedConfig::alt(0, 0, 0xFF, 0x00, 0x00)}, {ParsedConfig::alt(1, 0, 0xFF, 0xFF, 0xFF)}};
  libusb_endpoint_descriptor endpoint{};
  endpoint.bLength = 7;
  endpoint.bDescriptorType = LIBUSB_DT_ENDPOINT;
  endpoint.bEndpointAddress = 0x81;
  endpoint.extra = parsed.endpoint_extra.data();
  endpoint.extra_length = static_cast<int>(parsed.endpoint_extra.size());
  parsed.alts[0][0].bNumEndpoints = 1;
  parsed.alts[0][0].endpoint = &endpoint;
  EXPECT_TRUE(is_usb3_vision_config(parsed.finish()));

  parsed.endpoint_extra = association(1, 1, 0xEF, 0x04, 0x01);  // RNDIS instead
  endpoint.extra = parsed.endpoint_extra.data();
  EXPECT_FALSE(is_usb3_vision_config(parsed.finish()));
}

TEST(EventCount, WakesAWaiterWhenRaised) {
  EventCount count;
  EXPECT_FALSE(count.wait_beyond(0, milliseconds(0)));
  bool woke = false;
  std::thread waiter([&] { woke = count.wait_beyond(0, milliseconds(60000)); });
  std::this_thread::sleep_for(milliseconds(20));
  count.increment();
  waiter.join();
  EXPECT_TRUE(woke);
  EXPECT_EQ(count.value(), 1U);
  EXPECT_TRUE(count.wait_beyond(0, milliseconds(0)));  // already beyond: no wait
  EXPECT_FALSE(count.wait_beyond(1, milliseconds(10)));
}

TEST(UsbHotplugMonitor, StartsAndStopsOrSaysWhyNot) {
  const auto t0 = std::chrono::steady_clock::now();
  auto monitor = std::make_unique<UsbHotplugMonitor>(milliseconds(100));
  const auto started = std::chrono::steady_clock::now();
  std::printf("construction: %.2f ms\n", std::chrono::duration<double, std::milli>(started - t0).count());
  EXPECT_EQ(monitor->arrivals(), 0U);
  if (!monitor->available()) {
    EXPECT_FALSE(monitor->unavailable_reason().empty());
    EXPECT_EQ(monitor->present(), 0U);
    RUTD_SKIP_NEEDS_HARDWARE("USB hot-plug needs a usbfs (/dev/bus/usb) and libusb hot-plug support; here: "
                             << monitor->unavailable_reason());
  }
  EXPECT_TRUE(monitor->unavailable_reason().empty());
  std::printf("USB3 Vision devices attached: %u\n", monitor->present());
  std::this_thread::sleep_for(milliseconds(250));  // let the event loop run a few timeouts
  const auto stopping = std::chrono::steady_clock::now();
  monitor.reset();
  const double stop_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - stopping).count();
  std::printf("stop: %.2f ms (event timeout 100 ms)\n", stop_ms);
  EXPECT_LT(stop_ms, 2000.0);  // generous: the wake-up makes it near-instant, the timeout bounds it
}

TEST(UsbHotplugMonitor, WaitForArrivalTimesOutWhenNothingArrives) {
  UsbHotplugMonitor monitor;
  std::printf("available: %s %s\n", monitor.available() ? "yes" : "no", monitor.unavailable_reason().c_str());
  const std::uint64_t seen = monitor.arrivals();
  const auto t0 = std::chrono::steady_clock::now();
  const bool arrived = monitor.wait_for_arrival(seen, milliseconds(200));
  const double waited = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  std::printf("waited %.1f ms for a 200 ms timeout\n", waited);
  if (arrived) RUTD_SKIP_NEEDS_HARDWARE("a USB3 Vision device was plugged in during the test");
  EXPECT_EQ(monitor.arrivals(), seen);
  EXPECT_GE(waited, 199.0);  // it waits out the timeout (the fallback backoff relies on it)
}

TEST(UsbHotplugMonitor, WaitForArrivalEndsOnStopRequest) {
  UsbHotplugMonitor monitor;
  std::stop_source stop;
  std::thread stopper([&] {
    std::this_thread::sleep_for(milliseconds(50));
    stop.request_stop();
  });
  const auto t0 = std::chrono::steady_clock::now();
  const bool arrived = monitor.wait_for_arrival(monitor.arrivals(), milliseconds(60000), stop.get_token());
  const double waited = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  stopper.join();
  std::printf("stop request ended a 60 s wait after %.1f ms\n", waited);
  EXPECT_FALSE(arrived);
  EXPECT_LT(waited, 30000.0);  // far below the 60 s timeout: the stop request ended it
}

// Needs a person: set RUTD_TEST_REPLUG_SECONDS=N, start the test, then plug a USB3 Vision camera in
// (or unplug and replug it) within N seconds.
TEST(UsbHotplugMonitor, CountsARealCameraPluggedIn) {
  const char* seconds = std::getenv("RUTD_TEST_REPLUG_SECONDS");
  if (seconds == nullptr) {
    RUTD_SKIP_NEEDS_HARDWARE(
        "needs a USB3 Vision camera plugged in by hand: set RUTD_TEST_REPLUG_SECONDS=N and plug the camera in "
        "within N seconds of the start");
  }
  UsbHotplugMonitor monitor;
  if (!monitor.available()) RUTD_SKIP_NEEDS_HARDWARE("no USB hot-plug here: " << monitor.unavailable_reason());
  const std::uint64_t seen = monitor.arrivals();
  std::printf("plug a USB3 Vision camera in now (%s s)\n", seconds);
  ASSERT_TRUE(monitor.wait_for_arrival(seen, milliseconds(1000L * std::atol(seconds))));
  EXPECT_EQ(monitor.arrivals(), seen + 1);
  EXPECT_GE(monitor.present(), 1U);
}

}  // namespace
}  // namespace rutd
