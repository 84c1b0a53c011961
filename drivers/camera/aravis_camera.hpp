#pragma once
// Private to drivers/camera/ (it includes <arv.h>). One GenICam camera (GigE Vision or USB3 Vision) opened through
// Aravis: discovery, configuration from `source.aravis`, a stream of preallocated buffers, and conversion of a
// delivered buffer to a grey image.
//
// Thread safety: Aravis objects are not thread-safe, so an AravisCamera is used by one thread at a time.
// Ownership may move between threads (the connector thread opens it, acquisition uses it, the reaper
// destroys it) through a synchronised hand-over. Two things run on Aravis's own threads and touch only
// atomics or the FrameSignal: the stream callback (a buffer is ready) and the device's "control-lost"
// signal (heartbeat failed).
#include <arv.h>

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <memory>
#include <mutex>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include <opencv2/core.hpp>

#include "camera/aravis_config.hpp"
#include "camera/camera_error.hpp"
#include "camera/camera_list.hpp"
#include "pixel_convert.hpp"

namespace rutd {

// Wakes the acquisition thread when a stream has a buffer ready. Shared by both cameras of a pair.
class FrameSignal {
 public:
  void notify() noexcept;
  // Waits until notify() was called since `seen` (returned by mark()) or until timeout.
  void wait(std::uint64_t seen, std::chrono::microseconds timeout);
  std::uint64_t mark() const noexcept { return count_.load(std::memory_order_acquire); }

 private:
  std::atomic<std::uint64_t> count_{0};
  std::mutex mutex_;
  std::condition_variable cv_;
};

// A delivered image, as the pairing needs it.
struct CameraFrameInfo {
  std::uint64_t frame_id = 0;  // the camera's frame counter, unwrapped to 64 bits
  std::int64_t t_ns = 0;       // the camera's timestamp, nanoseconds
  bool complete = false;       // every packet arrived (ARV_BUFFER_STATUS_SUCCESS)
};

class AravisCamera {
 public:
  // Opens the camera with this Aravis device id. `label` names it in messages ("left camera GV01").
  // Throws CameraError("", ...) when it cannot be opened.
  AravisCamera(const std::string& device_id, std::string label);
  // Stops acquisition (unless the camera is lost) and releases it. Releasing a camera that no longer
  // answers blocks for Aravis's register timeouts (seconds): hand lost cameras to a thread that may wait.
  ~AravisCamera();
  AravisCamera(const AravisCamera&) = delete;
  AravisCamera& operator=(const AravisCamera&) = delete;

  // Applies the configuration: pixel format, binning, region, frame rate, synchronisation, exposure,
  // gain, GigE packet size/delay. Throws CameraError naming the configuration key. Things the camera
  // cannot do that do not change the images (PTP, metering region, auto limits) append a warning.
  void configure(const AravisSourceConfig& config, std::vector<std::string>& warnings);
  // Image size and pixel layout the camera now delivers (after configure()).
  cv::Size image_size() const noexcept { return size_; }
  CameraPixelLayout layout() const noexcept { return layout_; }

  // Creates the stream with `buffers` preallocated buffers and starts acquisition. `signal` is notified
  // from Aravis's stream thread for every finished buffer; the camera keeps it alive as long as its stream.
  void start(const AravisSourceConfig& config, std::shared_ptr<FrameSignal> signal, std::vector<std::string>& warnings);

  // A finished buffer, or nullptr. The buffer stays the camera's: give it back with requeue().
  ArvBuffer* try_pop() noexcept;
  void requeue(ArvBuffer* buffer) noexcept;
  CameraFrameInfo info(ArvBuffer* buffer) noexcept;
  // Converts the buffer's image to grey into `out` (reused when it fits), at the size the camera sent,
  // which may differ from the configured one. false: no data, or a payload shorter than the image.
  // cut_short (tests only): convert as if half of the payload had arrived.
  bool convert(ArvBuffer* buffer, cv::Mat& out, bool cut_short = false) noexcept;

  // Fires TriggerSoftware. false when the camera did not take the command.
  bool software_trigger() noexcept;
  // The device's heartbeat failed (set from Aravis's thread).
  bool control_lost() const noexcept { return control_lost_.load(std::memory_order_acquire); }
  // From now on the destructor does not talk to the camera (it is gone).
  void mark_lost() noexcept { lost_ = true; }

  // Name and current value of the features rutd sets, for `rutd cameras`.
  std::vector<std::pair<std::string, std::string>> feature_values();

  // Where the camera was found (discovery's listing), kept to find it again after a loss.
  void remember(CameraListing listing) { listing_ = std::move(listing); }
  const CameraListing& listing() const noexcept { return listing_; }
  const std::string& label() const noexcept { return label_; }

 private:
  static void on_control_lost(ArvDevice* device, gpointer self);
  static void on_stream_event(void* signal, ArvStreamCallbackType type, ArvBuffer* buffer);
  void set_pixel_format(const AravisSourceConfig& config);
  void set_geometry(const AravisSourceConfig& config);
  void set_sync(const AravisSourceConfig& config, std::vector<std::string>& warnings);
  void set_exposure_and_gain(const AravisSourceConfig& config, std::vector<std::string>& warnings);
  void set_gige(const AravisSourceConfig& config, std::vector<std::string>& warnings);
  [[noreturn]] void fail(const std::string& field, const std::string& what, GError* error);
  bool has(const char* feature);

  std::string label_;
  CameraListing listing_;
  ArvCamera* camera_ = nullptr;
  ArvDevice* device_ = nullptr;  // owned by camera_
  ArvStream* stream_ = nullptr;
  std::shared_ptr<FrameSignal> signal_;
  gulong control_lost_handler_ = 0;
  std::atomic<bool> control_lost_{false};
  bool lost_ = false;
  bool acquiring_ = false;
  bool gige_ = false;
  bool short_frame_ids_ = false;  // GigE Vision 1.x block ids: 16 bits, 0 skipped
  cv::Size size_;
  CameraPixelLayout layout_ = CameraPixelLayout::Mono8;
  std::uint64_t last_raw_id_ = 0;
  std::uint64_t id_base_ = 0;
  bool have_id_ = false;
};

}  // namespace rutd
