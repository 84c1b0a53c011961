#pragma once
// Two of Aravis's own fake GigE Vision cameras (real GVCP/GVSP peers over UDP) on 127.0.0.1 and
// 127.0.0.2, whose images are the synthetic renderer's left and right views of the same instant.
//
// The fake cameras stamp each frame with the wall clock rounded to their frame period, so two of them
// at the same rate behave like a PTP-synchronised pair. The fill callback picks the rendered view by that
// timestamp: view (t / period) mod K, the same instant for both cameras. A pair put together from two
// different instants shows the rut moved along travel by speed * period, which the measurement notices.
#include <arpa/inet.h>
#include <arv.h>
#include <ifaddrs.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <array>
#include <atomic>
#include <cstring>
#include <memory>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "skip_policy.hpp"
#include "synthetic/synthetic_renderer.hpp"

namespace rutd::test {

inline constexpr std::array<const char*, 2> kFakeAddress{"127.0.0.1", "127.0.0.2"};
inline constexpr std::array<const char*, 2> kFakeSerial{"RUTDL01", "RUTDR01"};
inline constexpr std::int64_t kFakePeriodNs = 40'000'000;  // the fake camera's default 25 Hz

// Empty when both loopback addresses are on an interface (the fake camera looks its address up there)
// and GVCP's port is free on them; else what is missing.
inline std::string fake_rig_unavailable() {
  const std::string hint =
      " (a network namespace of its own: run it through ctest, which uses tests/aravis/in_netns.sh)";
  for (const char* address : kFakeAddress) {
    bool assigned = false;
    ifaddrs* list = nullptr;
    if (getifaddrs(&list) == 0) {
      for (const ifaddrs* i = list; i != nullptr; i = i->ifa_next) {
        char text[INET_ADDRSTRLEN] = {};
        if (i->ifa_addr != nullptr && i->ifa_addr->sa_family == AF_INET &&
            inet_ntop(AF_INET, &reinterpret_cast<const sockaddr_in*>(i->ifa_addr)->sin_addr, text, sizeof text) &&
            std::string(text) == address)
          assigned = true;
      }
      freeifaddrs(list);
    }
    if (!assigned) return std::string("needs the address ") + address + " on an interface" + hint;
    const int fd = socket(AF_INET, SOCK_DGRAM, 0);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_port = htons(3956);
    inet_pton(AF_INET, address, &a.sin_addr);
    const bool ok = fd >= 0 && bind(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) == 0;
    if (fd >= 0) close(fd);
    if (!ok) return std::string("needs UDP port 3956 free on ") + address + hint;
  }
  return {};
}

class FakeStereoRig {
 public:
  // Renders `views` instants of the scene (frame i at i * period) and starts both cameras.
  FakeStereoRig(SyntheticRendererConfig params, int views) : renderer_(adjusted(params)) {
    for (std::size_t s = 0; s < 2; ++s) feeds_[s] = std::make_unique<Feed>();
    StereoFrame f;
    for (int i = 0; i < views; ++i) {
      renderer_.render(static_cast<std::uint64_t>(i), f);
      feeds_[0]->views.push_back(f.left.clone());
      feeds_[1]->views.push_back(f.right.clone());
      for (std::size_t s = 0; s < 2; ++s) {
        feeds_[s]->views16.emplace_back();
        feeds_[s]->views.back().convertTo(feeds_[s]->views16.back(), CV_16U, 257);
      }
    }
    start(0);
    start(1);
  }
  ~FakeStereoRig() {
    stop(0);
    stop(1);
  }

  void start(std::size_t side) {
    if (cameras_[side] != nullptr) return;
    cameras_[side] = arv_gv_fake_camera_new(kFakeAddress[side], kFakeSerial[side]);
    ASSERT_TRUE(arv_gv_fake_camera_is_running(cameras_[side])) << kFakeAddress[side];
    arv_fake_camera_set_fill_pattern(arv_gv_fake_camera_get_fake_camera(cameras_[side]), &FakeStereoRig::fill,
                                     feeds_[side].get());
  }
  // Gone from the network at once, as an unplugged camera.
  void stop(std::size_t side) {
    if (cameras_[side] == nullptr) return;
    g_object_unref(cameras_[side]);
    cameras_[side] = nullptr;
  }

  // The camera's Width register, as another program reconfiguring it behind rutd's back would set it:
  // its next frames are that wide (a smaller width fits the buffers rutd allocated).
  void set_width(std::size_t side, unsigned width) {
    ASSERT_NE(cameras_[side], nullptr);
    ASSERT_TRUE(arv_fake_camera_write_register(arv_gv_fake_camera_get_fake_camera(cameras_[side]),
                                               ARV_FAKE_CAMERA_REGISTER_WIDTH, width));
  }

  const SyntheticRenderer& renderer() const { return renderer_; }
  const StereoCalibration& calibration() const { return renderer_.calibration(); }
  // The rendered views the cameras send (8-bit, and x 257 as 16-bit): view i is the renderer's frame i.
  const std::vector<cv::Mat>& views(std::size_t side) const { return feeds_[side]->views; }
  const std::vector<cv::Mat>& views16(std::size_t side) const { return feeds_[side]->views16; }

 private:
  struct Feed {
    std::vector<cv::Mat> views;    // CV_8UC1, read-only once the cameras run
    std::vector<cv::Mat> views16;  // the same as CV_16UC1 (x 257), for Mono16
  };

  static SyntheticRendererConfig adjusted(SyntheticRendererConfig p) {
    p.fps = 1e9 / kFakePeriodNs;  // the renderer's frame i is the fake cameras' period i
    return p;
  }

  // Runs on the fake camera's thread for every frame it sends.
  static void fill(ArvBuffer* buffer, void* data, guint32, guint32, ArvPixelFormat format) {
    Feed& feed = *static_cast<Feed*>(data);
    const std::int64_t t = static_cast<std::int64_t>(arv_buffer_get_timestamp(buffer));
    const std::size_t index = static_cast<std::size_t>((t + kFakePeriodNs / 2) / kFakePeriodNs) % feed.views.size();
    const cv::Mat& view = format == ARV_PIXEL_FORMAT_MONO_16 ? feed.views16[index] : feed.views[index];
    const int width = arv_buffer_get_image_width(buffer), height = arv_buffer_get_image_height(buffer);
    auto* out = static_cast<unsigned char*>(const_cast<void*>(arv_buffer_get_data(buffer, nullptr)));
    if (out == nullptr || width > view.cols || height > view.rows) return;  // rutd checks sizes itself
    const std::size_t row_bytes = static_cast<std::size_t>(width) * view.elemSize();
    for (int y = 0; y < height; ++y) std::memcpy(out + static_cast<std::size_t>(y) * row_bytes, view.ptr(y), row_bytes);
  }

  SyntheticRenderer renderer_;
  std::array<std::unique_ptr<Feed>, 2> feeds_;
  std::array<ArvGvFakeCamera*, 2> cameras_{};
};

}  // namespace rutd::test
