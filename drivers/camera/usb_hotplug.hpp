#pragma once
// USB3 Vision hot-plug: tells the camera driver the moment a USB3 Vision camera is plugged in, so a lost
// camera is reopened as soon as it is back instead of at the end of the reconnect backoff.
//
// Which devices count. A device is a USB3 Vision device when its configuration holds a USB3 Vision
// Device Control interface, or an interface association for such a function: class 0xEF
// (Miscellaneous), subclass 0x05 (USB3 Vision), protocol 0x00 (Device Control). Reference: the USB3
// Vision standard (AIA, version 1.0 and later), in its USB descriptor requirements, gives the device's
// interface association function class/subclass/protocol 0xEF/0x05/0x00 and its interfaces class 0xEF,
// subclass 0x05 and protocol 0x00 (Device Control, mandatory), 0x01 (Device Event, optional) or 0x02
// (Device Streaming, optional); USB-IF's class-code table lists EFh/05h/00h as "USB3 Vision Device".
// Aravis (arvuvinterfaceprivate.h) and the Linux u3v kernel driver match the same triple, and so does
// systemd/60-rutd-usb3vision.rules (ID_USB_INTERFACES "*:ef0500:*"). Event and streaming interfaces
// alone do not make a device USB3 Vision: only the control interface lets a host talk to it.
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <mutex>
#include <span>
#include <stop_token>
#include <string>
#include <thread>
#include <utility>
#include <vector>

struct libusb_context;
struct libusb_device;
struct libusb_config_descriptor;

namespace rutd {

inline constexpr std::uint8_t kUsbClassMiscellaneous = 0xEF;
inline constexpr std::uint8_t kUsb3VisionSubclass = 0x05;
inline constexpr std::uint8_t kUsb3VisionProtocolControl = 0x00;
inline constexpr std::uint8_t kUsb3VisionProtocolEvent = 0x01;
inline constexpr std::uint8_t kUsb3VisionProtocolStreaming = 0x02;

// True when a run of raw USB descriptors (a configuration descriptor as the device sends it, wTotalLength
// bytes: configuration, interface association, interface, endpoint and class-specific descriptors one
// after the other, each starting with bLength, bDescriptorType) holds a USB3 Vision Device Control
// interface (type 0x04) or interface association (type 0x0B). Reads only whole descriptors inside the
// span; stops at a malformed one (bLength < 2 or running past the end).
bool is_usb3_vision_descriptors(std::span<const std::uint8_t> descriptors) noexcept;

// The same test on a configuration as libusb parses it: every alternate setting of every interface, and
// the interface associations libusb leaves among the `extra` bytes of the configuration, interfaces and
// endpoints.
bool is_usb3_vision_config(const libusb_config_descriptor& config) noexcept;

// A counter that one thread raises and other threads wait on.
// Thread safety: every member may be called from any thread.
class EventCount {
 public:
  std::uint64_t value() const noexcept { return value_.load(std::memory_order_acquire); }

  // Adds one and wakes every waiter.
  void increment();

  // Waits until value() > seen, at most `timeout`, or until `stop` is requested. Returns value() > seen.
  bool wait_beyond(std::uint64_t seen, std::chrono::milliseconds timeout, std::stop_token stop = {});

 private:
  std::mutex mutex_;  // orders increment() against a waiter's check-then-sleep
  std::condition_variable_any changed_;
  std::atomic<std::uint64_t> value_{0};
};

// Watches USB for USB3 Vision devices arriving and leaving: one libusb context, one hot-plug callback
// (every vendor and product; the callback keeps the USB3 Vision devices) and one event thread.
//
// Contract
// - Never throws for a platform without hot-plug: when libusb_init fails (no usbfs, no permission),
//   libusb has no hot-plug support, or the callback cannot be registered, available() is false,
//   unavailable_reason() says why, no thread runs, and wait_for_arrival() simply waits out its timeout,
//   so the caller's reconnect backoff works unchanged.
// - Devices attached at construction are known (present()) but are not arrivals: arrivals() counts
//   USB3 Vision devices plugged in since then. A device is counted once per plug-in even if libusb
//   reports it twice.
// - The libusb thread only classifies the device from its cached descriptors, counts and notifies; it
//   never opens the device or calls Aravis. Reopening the camera is the waiter's job.
// - Thread safety: arrivals(), departures(), present(), event_errors() and wait_for_arrival() may be
//   called from any thread; available() and unavailable_reason() are fixed at construction. The
//   destructor must not run while another thread is inside a member (stop the waiting thread first; its
//   stop_token makes wait_for_arrival() return at once).
// - Stopping: the destructor wakes the event thread with libusb_interrupt_event_handler() and joins it;
//   the event loop's timeout (event_timeout) bounds the wait should the wake-up be missed.
//
// Intended use in a camera driver thread:
//   const std::uint64_t seen = monitor.arrivals();   // read BEFORE trying, so no arrival is missed
//   if (!try_open_camera()) monitor.wait_for_arrival(seen, backoff, stop_token);
class UsbHotplugMonitor {
 public:
  static constexpr std::chrono::milliseconds kDefaultEventTimeout{100};

  explicit UsbHotplugMonitor(std::chrono::milliseconds event_timeout = kDefaultEventTimeout);
  ~UsbHotplugMonitor();
  UsbHotplugMonitor(const UsbHotplugMonitor&) = delete;
  UsbHotplugMonitor& operator=(const UsbHotplugMonitor&) = delete;

  bool available() const noexcept { return available_; }
  // Why the monitor is not available; empty when it is.
  const std::string& unavailable_reason() const noexcept { return reason_; }
  std::chrono::milliseconds event_timeout() const noexcept { return event_timeout_; }

  // USB3 Vision devices plugged in since construction.
  std::uint64_t arrivals() const noexcept { return arrivals_.value(); }
  // USB3 Vision devices unplugged since construction (those attached at construction included).
  std::uint64_t departures() const noexcept { return departures_.load(std::memory_order_acquire); }
  // USB3 Vision devices attached now.
  std::uint32_t present() const noexcept { return present_.load(std::memory_order_acquire); }
  // Times libusb's event handling failed (the thread then pauses one event timeout and goes on), or a
  // device could not be recorded for want of memory.
  std::uint64_t event_errors() const noexcept { return event_errors_.load(std::memory_order_relaxed); }

  // Waits until arrivals() > seen (true), `timeout` passes or `stop` is requested (false unless a device
  // arrived meanwhile). Without hot-plug it waits out the timeout (or the stop request).
  bool wait_for_arrival(std::uint64_t seen, std::chrono::milliseconds timeout, std::stop_token stop = {}) {
    return arrivals_.wait_beyond(seen, timeout, std::move(stop));
  }

 private:
  friend struct UsbHotplugCallback;

  void run(std::stop_token stop);
  void on_arrived(libusb_device* device);
  void on_left(libusb_device* device);
  void release() noexcept;

  std::chrono::milliseconds event_timeout_;
  libusb_context* context_ = nullptr;
  int callback_handle_ = 0;
  bool callback_registered_ = false;
  bool available_ = false;
  std::string reason_;

  // The USB3 Vision devices attached now, each holding one libusb reference. Touched only by the hot-plug
  // callback: on the constructing thread while it enumerates (enumerating_ true), then on the event
  // thread; released after that thread is joined.
  std::vector<libusb_device*> known_;
  bool enumerating_ = false;

  EventCount arrivals_;
  std::atomic<std::uint64_t> departures_{0};
  std::atomic<std::uint32_t> present_{0};
  std::atomic<std::uint64_t> event_errors_{0};

  std::jthread thread_;  // last: started when everything above is ready, joined first
};

}  // namespace rutd
