#include "usb_hotplug.hpp"

#include <libusb.h>
#include <sys/time.h>

#include <algorithm>
#include <system_error>

namespace rutd {

namespace {

constexpr std::uint8_t kDescriptorInterface = 0x04;             // LIBUSB_DT_INTERFACE
constexpr std::uint8_t kDescriptorInterfaceAssociation = 0x0B;  // LIBUSB_DT_INTERFACE_ASSOCIATION
constexpr std::size_t kInterfaceLength = 9;
constexpr std::size_t kInterfaceAssociationLength = 8;

bool is_usb3_vision_control(std::uint8_t cls, std::uint8_t subclass, std::uint8_t protocol) noexcept {
  return cls == kUsbClassMiscellaneous && subclass == kUsb3VisionSubclass && protocol == kUsb3VisionProtocolControl;
}

bool extra_is_usb3_vision(const unsigned char* extra, int length) noexcept {
  if (extra == nullptr || length <= 0) return false;
  return is_usb3_vision_descriptors({extra, static_cast<std::size_t>(length)});
}

// Whether any configuration of `device` is USB3 Vision. Uses only libusb's cached descriptors, which is
// what libusb allows inside an arrival callback (no I/O on the device).
bool device_is_usb3_vision(libusb_device* device) noexcept {
  libusb_device_descriptor dd{};
  if (libusb_get_device_descriptor(device, &dd) != LIBUSB_SUCCESS) return false;
  for (std::uint8_t i = 0; i < dd.bNumConfigurations; ++i) {
    libusb_config_descriptor* config = nullptr;
    if (libusb_get_config_descriptor(device, i, &config) != LIBUSB_SUCCESS || config == nullptr) continue;
    const bool yes = is_usb3_vision_config(*config);
    libusb_free_config_descriptor(config);
    if (yes) return true;
  }
  return false;
}

std::string libusb_error_text(int rc) { return std::string(libusb_error_name(rc)) + " (" + libusb_strerror(rc) + ")"; }

}  // namespace

bool is_usb3_vision_descriptors(std::span<const std::uint8_t> d) noexcept {
  std::size_t at = 0;
  while (d.size() - at >= 2) {
    const std::size_t length = d[at];
    if (length < 2 || length > d.size() - at) return false;  // malformed: trust nothing after it
    const std::uint8_t type = d[at + 1];
    if (type == kDescriptorInterface && length >= kInterfaceLength &&
        is_usb3_vision_control(d[at + 5], d[at + 6], d[at + 7])) {
      return true;  // bInterfaceClass, bInterfaceSubClass, bInterfaceProtocol
    }
    if (type == kDescriptorInterfaceAssociation && length >= kInterfaceAssociationLength &&
        is_usb3_vision_control(d[at + 4], d[at + 5], d[at + 6])) {
      return true;  // bFunctionClass, bFunctionSubClass, bFunctionProtocol
    }
    at += length;
  }
  return false;
}

bool is_usb3_vision_config(const libusb_config_descriptor& config) noexcept {
  // libusb files descriptors it does not parse (interface associations, class-specific ones) as the
  // `extra` bytes of the configuration, interface or endpoint they follow.
  if (extra_is_usb3_vision(config.extra, config.extra_length)) return true;
  if (config.interface == nullptr) return false;
  for (int i = 0; i < config.bNumInterfaces; ++i) {
    const libusb_interface& interface = config.interface[i];
    if (interface.altsetting == nullptr) continue;
    for (int a = 0; a < interface.num_altsetting; ++a) {
      const libusb_interface_descriptor& alt = interface.altsetting[a];
      if (is_usb3_vision_control(alt.bInterfaceClass, alt.bInterfaceSubClass, alt.bInterfaceProtocol)) {
        return true;
      }
      if (extra_is_usb3_vision(alt.extra, alt.extra_length)) return true;
      if (alt.endpoint == nullptr) continue;
      for (int e = 0; e < alt.bNumEndpoints; ++e) {
        if (extra_is_usb3_vision(alt.endpoint[e].extra, alt.endpoint[e].extra_length)) return true;
      }
    }
  }
  return false;
}

void EventCount::increment() {
  {
    // Under the mutex, so a waiter between its check and its sleep cannot miss the change.
    const std::lock_guard lock(mutex_);
    value_.fetch_add(1, std::memory_order_acq_rel);
  }
  changed_.notify_all();
}

bool EventCount::wait_beyond(std::uint64_t seen, std::chrono::milliseconds timeout, std::stop_token stop) {
  std::unique_lock lock(mutex_);
  return changed_.wait_for(lock, stop, timeout, [&] { return value_.load(std::memory_order_acquire) > seen; });
}

// The libusb callback: a C function pointer with access to the monitor's private members.
struct UsbHotplugCallback {
  static int LIBUSB_CALL on_event(libusb_context* /*context*/, libusb_device* device, libusb_hotplug_event event,
                                  void* user) noexcept {
    auto* monitor = static_cast<UsbHotplugMonitor*>(user);
    try {
      if (event == LIBUSB_HOTPLUG_EVENT_DEVICE_ARRIVED) {
        monitor->on_arrived(device);
      } else if (event == LIBUSB_HOTPLUG_EVENT_DEVICE_LEFT) {
        monitor->on_left(device);
      }
    } catch (...) {  // std::bad_alloc from the device list; nothing may unwind into libusb
      monitor->event_errors_.fetch_add(1, std::memory_order_relaxed);
    }
    return 0;  // stay registered
  }
};

UsbHotplugMonitor::UsbHotplugMonitor(std::chrono::milliseconds event_timeout)
    : event_timeout_(std::max(event_timeout, std::chrono::milliseconds{1})) {
#if defined(LIBUSB_API_VERSION) && LIBUSB_API_VERSION >= 0x0100010A
  int rc = libusb_init_context(&context_, nullptr, 0);
#else
  int rc = libusb_init(&context_);
#endif
  if (rc != LIBUSB_SUCCESS) {
    context_ = nullptr;
    reason_ = "libusb_init failed: " + libusb_error_text(rc) + "; is /dev/bus/usb present?";
    return;
  }
  if (libusb_has_capability(LIBUSB_CAP_HAS_HOTPLUG) == 0) {
    reason_ = "libusb has no hot-plug support on this platform";
    release();
    return;
  }

  known_.reserve(8);
  // ENUMERATE runs the callback here, on this thread, for the devices already attached: they become
  // known (so their departure is seen) without counting as arrivals.
  enumerating_ = true;
  rc = libusb_hotplug_register_callback(
      context_, static_cast<int>(LIBUSB_HOTPLUG_EVENT_DEVICE_ARRIVED | LIBUSB_HOTPLUG_EVENT_DEVICE_LEFT),
      LIBUSB_HOTPLUG_ENUMERATE, LIBUSB_HOTPLUG_MATCH_ANY, LIBUSB_HOTPLUG_MATCH_ANY, LIBUSB_HOTPLUG_MATCH_ANY,
      &UsbHotplugCallback::on_event, this, &callback_handle_);
  enumerating_ = false;
  if (rc != LIBUSB_SUCCESS) {
    reason_ = "libusb_hotplug_register_callback failed: " + libusb_error_text(rc);
    release();
    return;
  }
  callback_registered_ = true;

  try {
    thread_ = std::jthread([this](std::stop_token stop) { run(std::move(stop)); });
  } catch (const std::system_error& e) {
    reason_ = std::string("cannot start the USB event thread: ") + e.what();
    release();
    return;
  }
  available_ = true;
}

UsbHotplugMonitor::~UsbHotplugMonitor() {
  if (thread_.joinable()) {
    thread_.request_stop();
    libusb_interrupt_event_handler(context_);  // returns the thread from libusb_handle_events now
    thread_.join();
  }
  release();
}

void UsbHotplugMonitor::run(std::stop_token stop) {
  const auto us = std::chrono::duration_cast<std::chrono::microseconds>(event_timeout_).count();
  while (!stop.stop_requested()) {
    timeval tv{};
    tv.tv_sec = static_cast<time_t>(us / 1000000);
    tv.tv_usec = static_cast<suseconds_t>(us % 1000000);
    const int rc = libusb_handle_events_timeout_completed(context_, &tv, nullptr);
    if (rc == LIBUSB_SUCCESS || rc == LIBUSB_ERROR_INTERRUPTED) continue;
    // A failing event loop would otherwise spin a core; count it and pause one timeout (or until stop).
    event_errors_.fetch_add(1, std::memory_order_relaxed);
    std::mutex mutex;
    std::condition_variable_any never;
    std::unique_lock lock(mutex);
    never.wait_for(lock, stop, event_timeout_, [] { return false; });
  }
}

void UsbHotplugMonitor::on_arrived(libusb_device* device) {
  if (std::find(known_.begin(), known_.end(), device) != known_.end()) return;  // reported twice
  if (!device_is_usb3_vision(device)) return;
  known_.push_back(device);
  libusb_ref_device(device);  // keeps the pointer unique until it leaves
  present_.fetch_add(1, std::memory_order_acq_rel);
  if (!enumerating_) arrivals_.increment();
}

void UsbHotplugMonitor::on_left(libusb_device* device) {
  // Only the pointer is compared: libusb allows no descriptor read on a device that has left.
  const auto it = std::find(known_.begin(), known_.end(), device);
  if (it == known_.end()) return;
  known_.erase(it);
  // Safe inside the departure callback: libusb holds its own reference until the callback returns, and
  // dropping ours does no I/O on the departed device.
  libusb_unref_device(device);
  present_.fetch_sub(1, std::memory_order_acq_rel);
  departures_.fetch_add(1, std::memory_order_acq_rel);
}

void UsbHotplugMonitor::release() noexcept {
  if (context_ == nullptr) return;
  if (callback_registered_) libusb_hotplug_deregister_callback(context_, callback_handle_);
  callback_registered_ = false;
  for (libusb_device* device : known_) libusb_unref_device(device);
  known_.clear();
  libusb_exit(context_);
  context_ = nullptr;
}

}  // namespace rutd
