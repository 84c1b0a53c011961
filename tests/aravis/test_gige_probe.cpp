// The GVCP discovery probe used to see a lost GigE Vision camera come back: its bytes against the worked
// example in gige_probe.hpp (GigE Vision's GVCP header layout), and its answer against Aravis's fake
// camera, present and absent.
#include <array>
#include <chrono>
#include <cstdio>

#include <gtest/gtest.h>

#include "aravis/fake_stereo_rig.hpp"
#include "gige_probe.hpp"

namespace rutd {
namespace {

TEST(GigeProbe, CommandAndAnswerBytesFollowGvcp) {
  std::array<std::uint8_t, 8> command{};
  gvcp_discovery_command(1, command);
  EXPECT_EQ(command, (std::array<std::uint8_t, 8>{0x42, 0x11, 0x00, 0x02, 0x00, 0x00, 0x00, 0x01}));
  gvcp_discovery_command(0xBEEF, command);
  EXPECT_EQ(command[6], 0xBE);
  EXPECT_EQ(command[7], 0xEF);

  std::array<std::uint8_t, 256> ack{0x00, 0x00, 0x00, 0x03, 0x00, 0xf8, 0xBE, 0xEF};
  EXPECT_TRUE(gvcp_is_discovery_ack(ack, 0xBEEF));
  EXPECT_FALSE(gvcp_is_discovery_ack(ack, 0xBEF0));                       // another request's answer
  EXPECT_FALSE(gvcp_is_discovery_ack(std::span(ack.data(), 7), 0xBEEF));  // too short
  ack[1] = 0x06;                                                          // an error status
  EXPECT_FALSE(gvcp_is_discovery_ack(ack, 0xBEEF));
  ack[1] = 0x00;
  ack[3] = 0x81;  // READREG_ACK, not DISCOVERY_ACK
  EXPECT_FALSE(gvcp_is_discovery_ack(ack, 0xBEEF));
  EXPECT_FALSE(gige_camera_answers("not-an-address", std::chrono::milliseconds(10)));
}

TEST(GigeProbe, FakeCameraAnswersWhenPresentAndNotWhenGone) {
  if (const std::string why = test::fake_rig_unavailable(); !why.empty()) RUTD_SKIP_NEEDS_INSTALLED(why);
  ArvGvFakeCamera* camera = arv_gv_fake_camera_new(test::kFakeAddress[1], test::kFakeSerial[1]);
  ASSERT_TRUE(arv_gv_fake_camera_is_running(camera));
  using Clock = std::chrono::steady_clock;
  auto t0 = Clock::now();
  EXPECT_TRUE(gige_camera_answers(test::kFakeAddress[1], std::chrono::milliseconds(500)));
  const double present_ms = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
  EXPECT_FALSE(gige_camera_answers(test::kFakeAddress[0], std::chrono::milliseconds(100)));  // nobody there
  g_object_unref(camera);
  t0 = Clock::now();
  EXPECT_FALSE(gige_camera_answers(test::kFakeAddress[1], std::chrono::milliseconds(100)));
  const double absent_ms = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
  std::printf("answer from a present camera after %.2f ms; an absent one given up after %.0f ms\n", present_ms,
              absent_ms);
}

}  // namespace
}  // namespace rutd
