#include "aravis_camera.hpp"

#include <array>
#include <fstream>
#include <memory>

#include <fmt/format.h>

namespace rutd {
namespace {

std::string text(const char* s) { return s != nullptr ? std::string(s) : std::string(); }

// Frees a GError when it goes out of scope.
struct ErrorGuard {
  GError* error = nullptr;
  ~ErrorGuard() { g_clear_error(&error); }
  GError** operator&() { return &error; }
  explicit operator bool() const { return error != nullptr; }
};

const char* sync_name(CameraSync s) {
  switch (s) {
    case CameraSync::FreeRun: return "free_run";
    case CameraSync::SoftwareTrigger: return "software_trigger";
    case CameraSync::HardwareTrigger: return "hardware_trigger";
  }
  return "?";
}

// The kernel's cap on a socket receive buffer (net.core.rmem_max), 0 when unknown.
long kernel_rmem_max() {
  std::ifstream in("/proc/sys/net/core/rmem_max");
  long value = 0;
  in >> value;
  return in ? value : 0;
}

}  // namespace

std::vector<CameraListing> list_cameras() {
  arv_update_device_list();
  std::vector<CameraListing> cameras;
  const unsigned n = arv_get_n_devices();
  for (unsigned i = 0; i < n; ++i)
    cameras.push_back({text(arv_get_device_id(i)), text(arv_get_device_protocol(i)), text(arv_get_device_vendor(i)),
                       text(arv_get_device_model(i)), text(arv_get_device_serial_nbr(i)),
                       text(arv_get_device_address(i)), text(arv_get_device_physical_id(i))});
  return cameras;
}

std::optional<CameraListing> find_camera(const std::vector<CameraListing>& cameras, const std::string& selector) {
  for (const auto& c : cameras)
    if (!selector.empty() &&
        (selector == c.id || selector == c.serial || selector == c.address || selector == c.physical_id))
      return c;
  return std::nullopt;
}

void FrameSignal::notify() noexcept {
  {
    // The lock orders the increment with a waiter's check, so a wake-up is never lost.
    std::lock_guard lock(mutex_);
    count_.fetch_add(1, std::memory_order_release);
  }
  cv_.notify_one();
}

void FrameSignal::wait(std::uint64_t seen, std::chrono::microseconds timeout) {
  std::unique_lock lock(mutex_);
  cv_.wait_for(lock, timeout, [&] { return count_.load(std::memory_order_acquire) != seen; });
}

AravisCamera::AravisCamera(const std::string& device_id, std::string label) : label_(std::move(label)) {
  ErrorGuard error;
  camera_ = arv_camera_new(device_id.c_str(), &error);
  if (camera_ == nullptr)
    throw CameraError(
        "", fmt::format("{}: cannot open '{}': {}", label_, device_id, error ? error.error->message : "not found"));
  device_ = arv_camera_get_device(camera_);
  gige_ = arv_camera_is_gv_device(camera_);
  control_lost_handler_ = g_signal_connect(device_, "control-lost", G_CALLBACK(&AravisCamera::on_control_lost), this);
}

AravisCamera::~AravisCamera() {
  if (camera_ == nullptr) return;
  if (control_lost_handler_ != 0) g_signal_handler_disconnect(device_, control_lost_handler_);
  if (acquiring_ && !lost_) {
    GError* error = nullptr;
    arv_camera_stop_acquisition(camera_, &error);
    g_clear_error(&error);
  }
  if (stream_ != nullptr) g_object_unref(stream_);  // frees the buffers it holds
  g_object_unref(camera_);
}

void AravisCamera::on_control_lost(ArvDevice*, gpointer self) {
  static_cast<AravisCamera*>(self)->control_lost_.store(true, std::memory_order_release);
}

void AravisCamera::on_stream_event(void* signal, ArvStreamCallbackType type, ArvBuffer*) {
  // Runs on Aravis's stream thread: only wakes acquisition, which pops the buffer itself.
  if (type == ARV_STREAM_CALLBACK_TYPE_BUFFER_DONE) static_cast<FrameSignal*>(signal)->notify();
}

void AravisCamera::fail(const std::string& field, const std::string& what, GError* error) {
  throw CameraError(field, fmt::format("{}: {}{}{}", label_, what, error != nullptr ? ": " : "",
                                       error != nullptr ? error->message : ""));
}

bool AravisCamera::has(const char* feature) {
  GError* error = nullptr;
  const bool available = arv_device_is_feature_available(device_, feature, &error);
  g_clear_error(&error);
  return available;
}

void AravisCamera::configure(const AravisSourceConfig& c, std::vector<std::string>& warnings) {
  ErrorGuard error;
  arv_camera_stop_acquisition(camera_, &error);
  if (error) fail("", "cannot stop acquisition", error.error);
  set_pixel_format(c);
  set_geometry(c);
  set_sync(c, warnings);
  set_exposure_and_gain(c, warnings);
  if (gige_) set_gige(c, warnings);
}

void AravisCamera::set_pixel_format(const AravisSourceConfig& c) {
  // In order of preference; Mono16 falls back to the deepest unpacked format the sensor has.
  static const std::array<const char*, 1> mono8{"Mono8"};
  static const std::array<const char*, 3> mono16{"Mono16", "Mono12", "Mono10"};
  static const std::array<const char*, 4> bayer{"BayerRG8", "BayerGR8", "BayerBG8", "BayerGB8"};
  const char* const* first = mono8.data();
  std::size_t n = mono8.size();
  if (c.pixel_format == CameraPixelFormat::Mono16) first = mono16.data(), n = mono16.size();
  if (c.pixel_format == CameraPixelFormat::Bayer8) first = bayer.data(), n = bayer.size();
  for (std::size_t i = 0; i < n; ++i) {
    ErrorGuard error;
    if (!arv_device_is_enumeration_entry_available(device_, "PixelFormat", first[i], &error) || error) continue;
    arv_camera_set_pixel_format_from_string(camera_, first[i], &error);
    if (error) fail("pixel_format", fmt::format("cannot set PixelFormat {}", first[i]), error.error);
    layout_ = *pixel_layout_from_name(first[i]);
    return;
  }
  std::string offered;
  guint count = 0;
  ErrorGuard error;
  const char** names = arv_camera_dup_available_pixel_formats_as_strings(camera_, &count, &error);
  for (guint i = 0; names != nullptr && i < count; ++i) offered += (i ? ", " : "") + text(names[i]);
  g_free(names);
  fail("pixel_format", "has none of the pixel formats asked for; it offers " + offered, nullptr);
}

void AravisCamera::set_geometry(const AravisSourceConfig& c) {
  ErrorGuard error;
  if (c.binning > 1 || arv_camera_is_binning_available(camera_, nullptr)) {
    if (!arv_camera_is_binning_available(camera_, &error)) fail("binning", "has no binning", error.error);
    arv_camera_set_binning(camera_, c.binning, c.binning, &error);
    if (error) fail("binning", fmt::format("cannot bin {}x{}", c.binning, c.binning), error.error);
  }
  int width_min = 0, width_max = 0, height_min = 0, height_max = 0;
  arv_camera_get_width_bounds(camera_, &width_min, &width_max, &error);
  if (!error) arv_camera_get_height_bounds(camera_, &height_min, &height_max, &error);
  if (error) fail("roi", "cannot read its image size limits", error.error);
  // Offsets first go to 0 so that any width up to the sensor's is accepted.
  const int binning = std::max(c.binning, 1);
  const int x = c.roi.x / binning, y = c.roi.y / binning;
  const int width = c.roi.whole() ? width_max : c.roi.width / binning;
  const int height = c.roi.whole() ? height_max : c.roi.height / binning;
  arv_camera_set_region(camera_, 0, 0, width, height, &error);
  if (!error && (x != 0 || y != 0)) arv_camera_set_region(camera_, x, y, width, height, &error);
  if (error)
    fail("roi",
         fmt::format("cannot set region x {} y {} {}x{} (after binning {}; the camera allows {}..{} x {}..{}, width "
                     "step {})",
                     x, y, width, height, binning, width_min, width_max, height_min, height_max,
                     arv_camera_get_width_increment(camera_, nullptr)),
         error.error);
  int rx = 0, ry = 0, rw = 0, rh = 0;
  arv_camera_get_region(camera_, &rx, &ry, &rw, &rh, &error);
  if (error) fail("roi", "cannot read back its region", error.error);
  if (rw != width || rh != height || rx != x || ry != y)
    fail("roi",
         fmt::format("rounded the region to x {} y {} {}x{} (asked x {} y {} {}x{}): use its increments", rx, ry, rw,
                     rh, x, y, width, height),
         nullptr);
  size_ = cv::Size(rw, rh);
}

void AravisCamera::set_sync(const AravisSourceConfig& c, std::vector<std::string>& warnings) {
  ErrorGuard error;
  if (c.sync == CameraSync::FreeRun) {
    arv_camera_clear_triggers(camera_, &error);
    if (error) fail("sync", "cannot switch its triggers off", error.error);
    if (arv_camera_is_frame_rate_available(camera_, nullptr)) {
      arv_camera_set_frame_rate(camera_, c.fps, &error);
      if (error) fail("fps", fmt::format("cannot run at {} fps", c.fps), error.error);
    }
    // Timestamps of two free-running cameras only compare through a shared clock.
    const char* ptp = has("GevIEEE1588") ? "GevIEEE1588" : has("PtpEnable") ? "PtpEnable" : nullptr;
    if (ptp != nullptr) {
      arv_device_set_boolean_feature_value(device_, ptp, TRUE, &error);
      if (error) fail("sync", fmt::format("cannot enable {}", ptp), error.error);
    } else {
      warnings.push_back(label_ +
                         ": has neither GevIEEE1588 nor PtpEnable; its timestamps are taken as sharing one clock "
                         "with the other camera (the pair skew statistics will show if they do not)");
    }
    return;
  }
  const char* source = c.sync == CameraSync::SoftwareTrigger ? "Software" : c.trigger_line.c_str();
  if (c.sync == CameraSync::SoftwareTrigger && !arv_camera_is_software_trigger_supported(camera_, &error))
    fail("sync", "has no software trigger", error.error);
  arv_camera_set_trigger(camera_, source, &error);
  if (error)
    fail(c.sync == CameraSync::HardwareTrigger ? "trigger_line" : "sync",
         fmt::format("cannot trigger frames from {} ({})", source, sync_name(c.sync)), error.error);
}

void AravisCamera::set_exposure_and_gain(const AravisSourceConfig& c, std::vector<std::string>& warnings) {
  ErrorGuard error;
  // Auto functions of different vendors: the first family the camera has is used.
  auto set_first_float = [&](std::initializer_list<const char*> names, double value, const char* what) {
    for (const char* name : names)
      if (has(name)) {
        arv_device_set_float_feature_value(device_, name, value, &error);
        if (error) fail(what, fmt::format("cannot set {} to {}", name, value), error.error);
        return;
      }
    warnings.push_back(
        fmt::format("{}: no feature for the {} ({}), left as the camera has it", label_, what, fmt::join(names, ", ")));
  };
  if (c.exposure_auto) {
    if (!arv_camera_is_exposure_auto_available(camera_, &error))
      fail("exposure_auto", "has no ExposureAuto", error.error);
    arv_camera_set_exposure_time_auto(camera_, ARV_AUTO_CONTINUOUS, &error);
    if (error) fail("exposure_auto", "cannot switch ExposureAuto on", error.error);
    set_first_float({"AutoExposureTimeLowerLimit", "ExposureAutoLowerLimit", "AutoExposureTimeAbsLowerLimit"},
                    c.exposure_min_us, "exposure_min_us");
    set_first_float({"AutoExposureTimeUpperLimit", "ExposureAutoUpperLimit", "AutoExposureTimeAbsUpperLimit"},
                    c.exposure_max_us, "exposure_max_us");
  } else {
    if (arv_camera_is_exposure_auto_available(camera_, nullptr))
      arv_camera_set_exposure_time_auto(camera_, ARV_AUTO_OFF, &error);
    if (!error) arv_camera_set_exposure_time(camera_, c.exposure_us, &error);
    if (error) fail("exposure_us", fmt::format("cannot set exposure {} us", c.exposure_us), error.error);
  }
  if (c.gain_auto) {
    if (!arv_camera_is_gain_auto_available(camera_, &error)) fail("gain_auto", "has no GainAuto", error.error);
    arv_camera_set_gain_auto(camera_, ARV_AUTO_CONTINUOUS, &error);
    if (error) fail("gain_auto", "cannot switch GainAuto on", error.error);
    set_first_float({"AutoGainUpperLimit", "GainAutoUpperLimit", "AutoGainRawUpperLimit"}, c.gain_max_db,
                    "gain_max_db");
  } else if (arv_camera_is_gain_available(camera_, nullptr)) {
    if (arv_camera_is_gain_auto_available(camera_, nullptr)) arv_camera_set_gain_auto(camera_, ARV_AUTO_OFF, &error);
    if (!error) arv_camera_set_gain(camera_, c.gain_db, &error);
    if (error) fail("gain_db", fmt::format("cannot set gain {} dB", c.gain_db), error.error);
  }
  if ((c.exposure_auto || c.gain_auto) && !c.metering_region.whole()) {
    // Meter on the terrain only, so the sky or the vehicle's body does not drive the exposure.
    static const std::array<std::array<const char*, 4>, 2> families{{
        {"AutoFunctionAOIOffsetX", "AutoFunctionAOIOffsetY", "AutoFunctionAOIWidth", "AutoFunctionAOIHeight"},
        {"AutoFunctionROIOffsetX", "AutoFunctionROIOffsetY", "AutoFunctionROIWidth", "AutoFunctionROIHeight"},
    }};
    const std::array<int, 4> values{c.metering_region.x, c.metering_region.y, c.metering_region.width,
                                    c.metering_region.height};
    for (const auto& f : families) {
      if (!has(f[0])) continue;
      // Size first when shrinking keeps offset + size inside the image at every step.
      for (int i : {2, 3, 0, 1}) {
        arv_device_set_integer_feature_value(device_, f[i], values[i] / std::max(c.binning, 1), &error);
        if (error) fail("metering_region", fmt::format("cannot set {}", f[i]), error.error);
      }
      return;
    }
    warnings.push_back(label_ + ": no auto-function region feature; the auto functions meter the whole image");
  }
}

void AravisCamera::set_gige(const AravisSourceConfig& c, std::vector<std::string>& warnings) {
  ErrorGuard error;
  if (c.packet_size > 0) {
    arv_camera_gv_set_packet_size(camera_, c.packet_size, &error);
    if (error) fail("packet_size", fmt::format("cannot use {}-byte packets", c.packet_size), error.error);
  } else {
    const guint size = arv_camera_gv_auto_packet_size(camera_, &error);
    if (error) fail("packet_size", "packet size negotiation failed", error.error);
    if (size <= 1500)
      warnings.push_back(
          fmt::format("{}: {}-byte packets: jumbo frames (MTU 9000 on the camera's network interface) "
                      "cut the per-packet load, see the README",
                      label_, size));
  }
  if (c.packet_delay_ns > 0) {
    arv_camera_gv_set_packet_delay(camera_, c.packet_delay_ns, &error);
    if (error) fail("packet_delay_ns", "cannot set the inter-packet delay", error.error);
  }
  // GigE Vision 2 extended ids are 64-bit; otherwise block ids are 16 bits and wrap.
  short_frame_ids_ = !has("GevGVSPExtendedIDMode") ||
                     text(arv_device_get_string_feature_value(device_, "GevGVSPExtendedIDMode", nullptr)) != "On";
}

void AravisCamera::start(const AravisSourceConfig& c, std::shared_ptr<FrameSignal> signal,
                         std::vector<std::string>& warnings) {
  ErrorGuard error;
  signal_ = std::move(signal);
  if (arv_camera_is_gv_device(camera_) && !c.packet_socket)
    arv_camera_gv_set_stream_options(camera_, ARV_GV_STREAM_OPTION_PACKET_SOCKET_DISABLED);
  stream_ = arv_camera_create_stream(camera_, &AravisCamera::on_stream_event, signal_.get(), &error);
  if (stream_ == nullptr) fail("", "cannot open its stream", error.error);
  // One register read over the network: it sizes both the socket buffer and the stream buffers.
  const gint payload = static_cast<gint>(arv_camera_get_payload(camera_, &error));
  if (error) fail("", "cannot read its payload size", error.error);
  if (ARV_IS_GV_STREAM(stream_)) {
    // A frame arrives as one burst of packets faster than a busy thread drains them, and each packet costs
    // the kernel about twice its size in buffer accounting: one frame's worth (Aravis's automatic size)
    // overflows. Four frames ride out a late wake-up.
    const long asked = c.socket_buffer_bytes > 0 ? c.socket_buffer_bytes : 4L * payload;
    const long cap = kernel_rmem_max();
    if (cap > 0 && cap < asked)
      warnings.push_back(fmt::format(
          "{}: the kernel caps socket receive buffers at {} bytes (net.core.rmem_max), below the {} asked; "
          "frames will lose packets under load: install systemd/60-rutd-gige.conf or raise net.core.rmem_max",
          label_, cap, asked));
    g_object_set(stream_, "packet-resend",
                 c.packet_resend ? ARV_GV_STREAM_PACKET_RESEND_ALWAYS : ARV_GV_STREAM_PACKET_RESEND_NEVER,
                 "socket-buffer", ARV_GV_STREAM_SOCKET_BUFFER_FIXED, "socket-buffer-size", static_cast<gint>(asked),
                 nullptr);
  }
  for (int i = 0; i < c.buffers; ++i) arv_stream_push_buffer(stream_, arv_buffer_new(payload, nullptr));
  arv_camera_start_acquisition(camera_, &error);
  if (error) fail("", "cannot start acquisition", error.error);
  acquiring_ = true;
}

ArvBuffer* AravisCamera::try_pop() noexcept {
  return stream_ != nullptr ? arv_stream_try_pop_buffer(stream_) : nullptr;
}

void AravisCamera::requeue(ArvBuffer* buffer) noexcept { arv_stream_push_buffer(stream_, buffer); }

namespace {

// Aravis's own test before its image getters (arv_buffer_part_is_image, not exported): a payload that
// carries images and a first part that is a 2D image.
bool holds_image(ArvBuffer* buffer) noexcept {
  const ArvBufferPayloadType payload = arv_buffer_get_payload_type(buffer);
  if (payload != ARV_BUFFER_PAYLOAD_TYPE_IMAGE && payload != ARV_BUFFER_PAYLOAD_TYPE_EXTENDED_CHUNK_DATA &&
      payload != ARV_BUFFER_PAYLOAD_TYPE_MULTIPART)
    return false;
  return arv_buffer_get_n_parts(buffer) > 0 &&
         arv_buffer_get_part_data_type(buffer, 0) == ARV_BUFFER_PART_DATA_TYPE_2D_IMAGE;
}

}  // namespace

CameraFrameInfo AravisCamera::info(ArvBuffer* buffer) noexcept {
  CameraFrameInfo i;
  // Complete means an image we can read: Aravis also hands over buffers whose transfer succeeded with no
  // image in them (another payload type, no part), and its image getters assert on those.
  i.complete = arv_buffer_get_status(buffer) == ARV_BUFFER_STATUS_SUCCESS && holds_image(buffer);
  i.t_ns = static_cast<std::int64_t>(arv_buffer_get_timestamp(buffer));
  const std::uint64_t raw = arv_buffer_get_frame_id(buffer);
  if (!short_frame_ids_) {
    i.frame_id = raw;
    return i;
  }
  // 16-bit block ids run 1..65535 and skip 0: unwrap to a 64-bit count so that pairing by id survives a wrap.
  if (have_id_ && raw < last_raw_id_) id_base_ += 65535;
  have_id_ = true;
  last_raw_id_ = raw;
  i.frame_id = id_base_ + raw;
  return i;
}

bool AravisCamera::convert(ArvBuffer* buffer, cv::Mat& out, bool cut_short) noexcept {
  std::size_t bytes = 0;
  const void* data = arv_buffer_get_data(buffer, &bytes);
  if (cut_short) bytes /= 2;
  // An image of another size than configured is converted as it is: the pipeline compares every pair
  // with the calibration and raises CalibrationInvalid, which says what is wrong better than a missing
  // camera would (a camera reconfigured behind rutd's back, binning, another ROI).
  const int width = arv_buffer_get_image_width(buffer), height = arv_buffer_get_image_height(buffer);
  if (data == nullptr) return false;
  return convert_to_grey(layout_, data, bytes, width, height, out);
}

bool AravisCamera::software_trigger() noexcept {
  GError* error = nullptr;
  arv_camera_software_trigger(camera_, &error);
  const bool ok = error == nullptr;
  g_clear_error(&error);
  return ok;
}

std::vector<std::pair<std::string, std::string>> AravisCamera::feature_values() {
  static const std::array<const char*, 28> names{"DeviceVendorName",
                                                 "DeviceModelName",
                                                 "DeviceSerialNumber",
                                                 "DeviceFirmwareVersion",
                                                 "SensorWidth",
                                                 "SensorHeight",
                                                 "PixelFormat",
                                                 "Width",
                                                 "Height",
                                                 "OffsetX",
                                                 "OffsetY",
                                                 "BinningHorizontal",
                                                 "BinningVertical",
                                                 "AcquisitionFrameRate",
                                                 "TriggerSelector",
                                                 "TriggerMode",
                                                 "TriggerSource",
                                                 "ExposureAuto",
                                                 "ExposureTime",
                                                 "ExposureTimeAbs",
                                                 "GainAuto",
                                                 "Gain",
                                                 "GainRaw",
                                                 "GevIEEE1588",
                                                 "PtpEnable",
                                                 "GevSCPSPacketSize",
                                                 "GevSCPD",
                                                 "GevTimestampTickFrequency"};
  std::vector<std::pair<std::string, std::string>> values;
  for (const char* name : names) {
    if (!has(name)) continue;
    ArvGcNode* node = arv_device_get_feature(device_, name);
    GError* error = nullptr;
    std::string value;
    if (ARV_IS_GC_STRING(node) || ARV_IS_GC_ENUMERATION(node)) {
      value = ARV_IS_GC_ENUMERATION(node) ? text(arv_gc_enumeration_get_string_value(ARV_GC_ENUMERATION(node), &error))
                                          : text(arv_gc_string_get_value(ARV_GC_STRING(node), &error));
    } else if (ARV_IS_GC_FLOAT(node)) {
      value = fmt::format("{:g}", arv_gc_float_get_value(ARV_GC_FLOAT(node), &error));
    } else if (ARV_IS_GC_BOOLEAN(node)) {
      value = arv_gc_boolean_get_value(ARV_GC_BOOLEAN(node), &error) ? "true" : "false";
    } else if (ARV_IS_GC_INTEGER(node)) {
      value = std::to_string(arv_gc_integer_get_value(ARV_GC_INTEGER(node), &error));
    } else {
      continue;
    }
    if (error != nullptr) value = std::string("(unreadable: ") + error->message + ")";
    g_clear_error(&error);
    values.emplace_back(name, value);
  }
  return values;
}

}  // namespace rutd
