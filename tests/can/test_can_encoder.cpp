// The CAN encoder, the DBC file and the candump log, checked against independent tools: every frame is
// written to a candump log, decoded with config/rutd.dbc by canmatrix (tests/can/decode_candump.py, which
// also checks CRC and counters with its own code), and converted by can-utils' log2asc. Expected values
// come from the inputs and the signal ranges of the specification, not from the encoder.
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "can/can_encoder.hpp"
#include "can/candump_log.hpp"
#include "test_support.hpp"

namespace rutd {
namespace {

using test::quoted;
using test::read_text;
using test::run_shell;

namespace fs = std::filesystem;
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr const char* kPython = "/usr/bin/python3";

// ---------------------------------------------------------------------------------------------------
// Helpers: temporary folder, shell commands, the decoder's CSV.

fs::path make_temp_dir() {
  const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
  const fs::path dir =
      fs::temp_directory_path() / ("rutd_can_" + std::string(info->name()) + "_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

std::string decoder_unavailable() {
  if (!fs::exists(kPython)) return std::string(kPython) + " is needed (with python3-canmatrix)";
  if (run_shell(std::string(kPython) + " -c 'import canmatrix.formats' >/dev/null 2>&1") != 0) {
    return std::string("canmatrix for ") + kPython + " is needed (Debian package python3-canmatrix)";
  }
  return {};
}

struct DecodedSignal {
  int index = 0;
  std::int64_t t_ns = 0;
  std::string message;
  std::string signal;
  long long raw = 0;
  double phys = 0.0;
  std::string named;
  bool na = false;
};

struct DecoderRun {
  int exit_code = -1;
  std::vector<DecodedSignal> rows;
  std::string diagnostics;  // the script's stderr
};

std::vector<std::string> split_csv(const std::string& line) {
  std::vector<std::string> fields;
  std::stringstream ss(line);
  std::string field;
  while (std::getline(ss, field, ',')) fields.push_back(field);
  if (!line.empty() && line.back() == ',') fields.emplace_back();
  return fields;
}

DecoderRun run_decoder(const fs::path& log, const fs::path& dir) {
  const fs::path source(RUTD_SOURCE_DIR);
  const fs::path csv = dir / "decoded.csv";
  const fs::path err = dir / "decoder.err";
  DecoderRun run;
  run.exit_code =
      run_shell(std::string(kPython) + " " + quoted(source / "tests/can/decode_candump.py") + " " +
                quoted(source / "config/rutd.dbc") + " " + quoted(log) + " >" + quoted(csv) + " 2>" + quoted(err));
  run.diagnostics = read_text(err);
  std::ifstream in(csv);
  std::string line;
  std::getline(in, line);  // header
  while (std::getline(in, line)) {
    const auto f = split_csv(line);
    if (f.size() != 8) {
      ADD_FAILURE() << "bad decoder line: " << line;
      continue;
    }
    run.rows.push_back({std::stoi(f[0]), std::stoll(f[1]), f[2], f[3], std::stoll(f[4]),
                        std::strtod(f[5].c_str(), nullptr), f[6], f[7] == "1"});
  }
  return run;
}

// ---------------------------------------------------------------------------------------------------
// Expected decoded values, from the specification's signal ranges and resolutions.

struct Range {
  double min;
  double max;
  double step;
};
constexpr Range kDepth{0, 400, 0.1};
constexpr Range kWidth{0, 1000, 0.25};
constexpr Range kQualityPercent{0, 100, 0.4};
constexpr Range kArea{0, 655340, 10};
constexpr Range kPile{0, 200, 0.1};
constexpr Range kSlope{-30, 30, 0.02};
constexpr Range kCenter{-1000, 1000, 0.5};
constexpr Range kFrameRate{0, 655.34, 0.01};
constexpr Range kUncertainty{0, 40.94, 0.01};
constexpr Range kVerticalDisparity{-20, 20.94, 0.01};
constexpr Range kShare{0, 100, 0.4};
constexpr Range kSegmentEnd{0, 10485.74, 0.01};
constexpr Range kSegmentDepth{0, 409.4, 0.1};
constexpr Range kSegmentFrames{0, 4094, 1};
constexpr Range kSoilStrength{0, 6553.4, 0.1};
constexpr Range kSpeedKmh{-320, 335.34, 0.01};
constexpr Range kTrackDistance{0, 167772.14, 0.01};
constexpr Range kOldestUnsent{0, 65534, 1};

struct Expect {
  bool na = false;
  double value = 0.0;
  double tolerance = 0.0;
  std::string named;    // value-table text, checked when not empty
  bool ranged = false;  // a scaled quantity, whose all-ones raw value would mean "not available"
};

Expect physical(double v, const Range& r) {
  if (!std::isfinite(v)) return {true, 0, 0, {}};
  return {false, std::clamp(v, r.min, r.max), r.step / 2 + 1e-9, {}, true};
}
Expect exact(double v, std::string named = {}) { return {false, v, 1e-9, std::move(named), false}; }
Expect not_available() { return {true, 0, 0, {}}; }

std::string status_text(RutStatus s) {
  return static_cast<int>(s) < kRutStatusCount ? std::string(to_string(s)) : std::string("UNKNOWN");
}
double status_raw(RutStatus s) { return static_cast<int>(s) < kRutStatusCount ? static_cast<int>(s) : 15; }

using Expectations = std::map<std::pair<int, std::string>, Expect>;  // (frame index, signal) -> value

void expect_measurement(Expectations& e, int index, int counter, const RutMeasurement& m) {
  const bool ok = m.status == RutStatus::Ok;
  auto field = [&](double v, const Range& r) { return ok ? physical(v, r) : not_available(); };
  e[{index, "RutM1_Counter"}] = exact(counter);
  e[{index, "RutM1_Status"}] = exact(status_raw(m.status), status_text(m.status));
  e[{index, "RutDepth"}] = field(m.depth_mm, kDepth);
  e[{index, "RutWidth"}] = field(m.width_mm, kWidth);
  e[{index, "RutQuality"}] = field(m.quality * 100.0, kQualityPercent);
  e[{index, "RutArea"}] = field(m.area_mm2, kArea);
  e[{index + 1, "RutM2_Counter"}] = exact(counter);
  e[{index + 1, "RutM2_Status"}] = exact(status_raw(m.status), status_text(m.status));
  e[{index + 1, "RutLeftPile"}] = field(m.left_pile_mm, kPile);
  e[{index + 1, "RutRightPile"}] = field(m.right_pile_mm, kPile);
  e[{index + 1, "GroundSlope"}] = field(m.ground_slope_deg, kSlope);
  e[{index + 1, "RutCenterX"}] = field(m.center_x_mm, kCenter);
}

void expect_conditions(Expectations& e, int index, int counter, const RutMeasurement& m) {
  e[{index, "RutC_Counter"}] = exact(counter);
  e[{index, "RutC_Status"}] = exact(status_raw(m.status), status_text(m.status));
  const char* flags[] = {"Water",       "LeftLensObstructed", "RightLensObstructed", "LowLight",
                         "Overexposed", "Vegetation",         "CalibrationDrift",    "DepthUncertain"};
  for (int bit = 0; bit < 8; ++bit) e[{index, flags[bit]}] = exact((m.conditions >> bit) & 1U);
  e[{index, "DepthUncertainty"}] = physical(m.depth_uncertainty_mm, kUncertainty);
  e[{index, "VerticalDisparity"}] = physical(m.vertical_disparity_px, kVerticalDisparity);
  e[{index, "LeftObstructedShare"}] = physical(m.obstructed_left * 100.0, kShare);
  e[{index, "RightObstructedShare"}] = physical(m.obstructed_right * 100.0, kShare);
}

void expect_status(Expectations& e, int index, int counter, const SensorHealth& h) {
  e[{index, "RutS_Counter"}] = exact(counter);
  e[{index, "RutS_LastStatus"}] = exact(status_raw(h.last_status), status_text(h.last_status));
  e[{index, "NoCamera"}] = exact(h.no_camera);
  e[{index, "StaleFrames"}] = exact(h.stale_frames);
  e[{index, "CalibrationInvalid"}] = exact(h.calibration_invalid);
  e[{index, "LowTexture"}] = exact(h.low_texture);
  e[{index, "FrameDrops"}] = exact(h.frame_drops);
  e[{index, "CanTxDrops"}] = exact(h.can_tx_drops);
  e[{index, "BusOff"}] = exact(h.bus_off);
  e[{index, "RecordingError"}] = exact(h.recording_error);
  e[{index, "FrameRate"}] = physical(h.frame_rate_hz, kFrameRate);
  e[{index, "DroppedFrames"}] = exact(std::min<double>(h.dropped_frames, 16777214.0));
}

void expect_version(Expectations& e, int index, int counter, const SoftwareVersion& v) {
  e[{index, "RutV_Counter"}] = exact(counter);
  e[{index, "SwPackageRevision"}] = exact(v.revision);
  e[{index, "SwVersionMajor"}] = exact(v.major);
  e[{index, "SwVersionMinor"}] = exact(v.minor);
  e[{index, "SwVersionPatch"}] = exact(v.patch);
  e[{index, "SwModified"}] = exact(v.modified);
  e[{index, "SwCommitUnknown"}] = exact(!v.commit_known);
  e[{index, "SwCommit"}] = v.commit_known ? exact(v.commit_prefix) : not_available();
}

const char* advisory_text(Advisory a) {
  switch (a) {
    case Advisory::Unknown: return "UNKNOWN";
    case Advisory::Go: return "GO";
    case Advisory::Caution: return "CAUTION";
    case Advisory::NoGo: return "NO_GO";
  }
  return "";
}

void expect_segment(Expectations& e, int index, int counter, const Segment& g) {
  const double advisory = static_cast<int>(g.advisory);
  e[{index, "RutG_Counter"}] = exact(counter);
  e[{index, "RutG_Advisory"}] = exact(advisory, advisory_text(g.advisory));
  e[{index, "SegmentEnd"}] = physical(g.end_m, kSegmentEnd);
  e[{index, "SegmentMeanDepth"}] = physical(g.mean_depth_mm, kSegmentDepth);
  e[{index, "SegmentP95Depth"}] = physical(g.p95_depth_mm, kSegmentDepth);
  e[{index, "SegmentWorstStatus"}] =
      g.frames > 0 ? exact(status_raw(g.worst_status), status_text(g.worst_status)) : exact(15, "UNKNOWN");
  e[{index + 1, "RutGS_Counter"}] = exact(counter);
  e[{index + 1, "RutGS_Advisory"}] = exact(advisory, advisory_text(g.advisory));
  e[{index + 1, "SegmentMaxDepth"}] = physical(g.max_depth_mm, kSegmentDepth);
  e[{index + 1, "SegmentRefused"}] = g.frames > 0 ? physical(100.0 * g.refused / g.frames, kShare) : not_available();
  e[{index + 1, "SegmentFrames"}] = physical(g.frames, kSegmentFrames);
  e[{index + 1, "SegmentSoilStrength"}] = physical(g.soil_strength, kSoilStrength);
}

// RutMotion: the speed only when its state is OK, the distance whenever known, the fix as the position
// source says.
struct MotionCase {
  VehicleMotion motion;
  GeoFix position;  // Mode::None: no positioning source
};

void expect_motion(Expectations& e, int index, int counter, const MotionCase& c) {
  const char* states[] = {"OK", "NOT_AVAILABLE", "ERROR", "STALE", "NO_SOURCE"};
  const char* fixes[] = {"NO_SOURCE", "NO_FIX", "FIX_2D", "FIX_3D"};
  const int state = static_cast<int>(c.motion.state);
  e[{index, "RutMo_Counter"}] = exact(counter);
  e[{index, "SpeedState"}] = exact(state, states[state]);
  e[{index, "VehicleSpeed"}] =
      c.motion.state == SpeedState::Ok ? physical(c.motion.speed_mm_s * 3.6e-3, kSpeedKmh) : not_available();
  e[{index, "TrackDistance"}] = physical(c.motion.distance_m, kTrackDistance);
  const int fix = static_cast<int>(c.position.mode);
  e[{index, "PositionFix"}] = exact(fix == 0 ? 15 : fix, fixes[fix]);
}

void expect_uplink(Expectations& e, int index, int counter, const UplinkState& u) {
  e[{index, "RutU_Counter"}] = exact(counter);
  e[{index, "UplinkLink"}] = exact(u.link_up ? 1 : 0, u.link_up ? "UP" : "DOWN");
  e[{index, "UplinkQueued"}] = exact(static_cast<double>(std::min<std::uint64_t>(u.queued, 16777214)));
  e[{index, "UplinkOldestUnsent"}] = physical(u.oldest_unsent_s, kOldestUnsent);
  e[{index, "UplinkSendErrors"}] = exact(u.send_errors);
  e[{index, "UplinkQueueError"}] = exact(u.queue_error);
  e[{index, "UplinkDropped"}] = exact(u.dropped);
}

UplinkState uplink_case(std::mt19937& rng, int k) {
  std::bernoulli_distribution coin(0.5);
  UplinkState u;
  u.enabled = true;
  u.link_up = coin(rng);
  const std::uint64_t queued[] = {0, 16777214, 16777215, 5'000'000'000ULL};
  u.queued = k < 4 ? queued[k] : std::uniform_int_distribution<std::uint64_t>(0, 100000)(rng);
  const double oldest[] = {0.0, 65534.0, 1e6, -3.0, kNaN};
  u.oldest_unsent_s = k < 5 ? oldest[k] : std::uniform_real_distribution<double>(0, 3600)(rng);
  u.send_errors = coin(rng);
  u.queue_error = coin(rng);
  u.dropped = coin(rng);
  return u;
}

// The ends of every field, each state and fix, and random values spilling past both ends.
MotionCase motion_case(std::mt19937& rng, int k) {
  MotionCase c;
  auto uniform = [&](double lo, double hi) { return std::uniform_real_distribution<double>(lo, hi)(rng); };
  c.motion.state = static_cast<SpeedState>(k % 5);
  c.motion.speed_mm_s = uniform(-120000, 120000);  // beyond -320..335 km/h at both ends
  c.motion.distance_m = k % 7 == 3 ? kNaN : uniform(-10, 180000);
  c.position.mode = static_cast<GeoFix::Mode>(k % 4);
  const double speeds[] = {0.0, -320 / 3.6e-3, 335.34 / 3.6e-3, 7.2 / 3.6e-3, -0.004};
  if (k < 5) {
    c.motion.state = SpeedState::Ok;
    c.motion.speed_mm_s = speeds[k];
    c.motion.distance_m = k == 1 ? 167772.14 : k == 2 ? 0.0 : 12.34;
  }
  return c;
}

// The ends of every field, a segment without measurements, and random segments.
Segment segment_case(std::mt19937& rng, int k) {
  Segment g;
  g.index = static_cast<std::uint64_t>(k);
  g.start_m = k;
  g.end_m = k + 1.0;
  if (k == 0) return g;  // no measurement: depths NaN, frames 0, UNKNOWN
  auto uniform = [&](double lo, double hi) { return std::uniform_real_distribution<double>(lo, hi)(rng); };
  g.frames = k == 1 ? 5000 : std::uniform_int_distribution<std::uint32_t>(1, 200)(rng);
  g.refused = std::uniform_int_distribution<std::uint32_t>(0, g.frames)(rng);
  g.mean_depth_mm = k == 1 ? 500 : uniform(-5, 420);
  g.p95_depth_mm = uniform(-5, 420);
  g.max_depth_mm = uniform(-5, 420);
  g.end_m = k == 1 ? 20000 : uniform(0, 12000);
  g.soil_strength = k == 2 ? kNaN : uniform(-10, 7000);
  g.worst_status = static_cast<RutStatus>(k % kRutStatusCount);
  g.advisory = static_cast<Advisory>(k % 4);
  return g;
}

// ---------------------------------------------------------------------------------------------------
// Inputs: edge cases, every status, and random values spilling past both ends of every range.

RutMeasurement ok_measurement(double depth, double width, double left, double right, double area, double slope,
                              double center, double quality) {
  RutMeasurement m;
  m.status = RutStatus::Ok;
  m.depth_mm = depth;
  m.width_mm = width;
  m.left_pile_mm = left;
  m.right_pile_mm = right;
  m.area_mm2 = area;
  m.ground_slope_deg = slope;
  m.center_x_mm = center;
  m.quality = quality;
  return m;
}

double spill(std::mt19937& rng, const Range& r) {
  const double margin = 0.1 * (r.max - r.min);
  return std::uniform_real_distribution<double>(r.min - margin, r.max + margin)(rng);
}

RutMeasurement random_measurement(std::mt19937& rng, RutStatus status) {
  RutMeasurement m =
      ok_measurement(spill(rng, kDepth), spill(rng, kWidth), spill(rng, kPile), spill(rng, kPile), spill(rng, kArea),
                     spill(rng, kSlope), spill(rng, kCenter), spill(rng, kQualityPercent) / 100.0);
  m.status = status;
  m.conditions = static_cast<std::uint8_t>(std::uniform_int_distribution<int>(0, 255)(rng));
  m.depth_uncertainty_mm = spill(rng, kUncertainty);
  m.vertical_disparity_px = spill(rng, kVerticalDisparity);
  m.obstructed_left = spill(rng, kShare) / 100.0;
  m.obstructed_right = spill(rng, kShare) / 100.0;
  return m;
}

std::vector<RutMeasurement> measurement_cases() {
  std::vector<RutMeasurement> cases;
  cases.push_back(ok_measurement(0, 0, 0, 0, 0, 0, 0, 0));
  cases.push_back(ok_measurement(400, 1000, 200, 200, 655340, 30, 1000, 1));
  cases.push_back(ok_measurement(0, 0, 0, 0, 0, -30, -1000, 0));
  cases.push_back(ok_measurement(1e6, 5000, 300, 250, 1e7, 89, 5000, 1.5));                  // saturate high
  cases.push_back(ok_measurement(-5, -1, -3, -0.01, -100, -89, -5000, -0.2));                // saturate low
  cases.push_back(ok_measurement(123.45, 333.375, 17.25, 0.05, 12345, -0.01, 0.25, 0.502));  // half steps
  cases.push_back(ok_measurement(kInf, 500, 50, 50, 1000, -kInf, 0, 0.5));
  for (int nan_field = 0; nan_field < 8; ++nan_field) {
    double v[8] = {100, 300, 20, 30, 5000, 2.5, -150, 0.75};
    v[nan_field] = kNaN;
    cases.push_back(ok_measurement(v[0], v[1], v[2], v[3], v[4], v[5], v[6], v[7]));
  }
  std::mt19937 rng(20240601);
  for (int s = 0; s < kRutStatusCount; ++s) cases.push_back(random_measurement(rng, static_cast<RutStatus>(s)));
  cases.push_back(random_measurement(rng, static_cast<RutStatus>(13)));  // not a RutStatus value
  for (int i = 0; i < 200; ++i) cases.push_back(random_measurement(rng, RutStatus::Ok));
  return cases;
}

SensorHealth health_case(std::mt19937& rng, int k) {
  std::bernoulli_distribution coin(0.5);
  SensorHealth h;
  h.no_camera = coin(rng);
  h.stale_frames = coin(rng);
  h.calibration_invalid = coin(rng);
  h.low_texture = coin(rng);
  h.frame_drops = coin(rng);
  h.can_tx_drops = coin(rng);
  h.bus_off = coin(rng);
  h.recording_error = coin(rng);
  const double rates[] = {kNaN, -5.0, 0.0, 700.0, 655.34};
  h.frame_rate_hz = k < 5 ? rates[k] : std::uniform_real_distribution<double>(0, 120)(rng);
  const std::uint32_t drops[] = {0, 16777214, 16777215, 4000000000U};
  h.dropped_frames = k < 4 ? drops[k] : std::uniform_int_distribution<std::uint32_t>(0, 100000)(rng);
  h.last_status = static_cast<RutStatus>(k % 7 == 6 ? 12 : k % 7);
  return h;
}

// The ends of every field, a commit unknown, and random versions.
SoftwareVersion version_case(std::mt19937& rng, int k) {
  const SoftwareVersion fixed[] = {{0, 1, 0, 1, 0xA5905, true, false},
                                   {254, 254, 254, 14, 0xFFFFF, true, true},
                                   {0, 0, 0, 0, 0, true, false},
                                   {3, 2, 1, 2, 0, false, true}};
  if (k < 4) return fixed[k];
  auto byte = [&](int max) { return static_cast<std::uint8_t>(std::uniform_int_distribution<int>(0, max)(rng)); };
  std::bernoulli_distribution coin(0.5);
  return {byte(254), byte(254), byte(254), byte(14), std::uniform_int_distribution<std::uint32_t>(0, 0xFFFFF)(rng),
          coin(rng), coin(rng)};
}

constexpr std::int64_t kT0 = 1'700'000'000'000'000'000 + 987'654'321;  // not on a microsecond

// Encodes all cases in the order a daemon would send them (a status frame after every 10th measurement, a
// version frame after every third status frame) and writes them to `log_path`. Returns the expectations and the frames
// in log order.
std::pair<Expectations, std::vector<CanFrame>> write_log(const fs::path& log_path, std::vector<std::int64_t>& times) {
  CanEncoder encoder;
  std::ofstream log(log_path);
  CandumpLogWriter writer(log, "can0");
  Expectations expected;
  std::vector<CanFrame> frames;
  std::mt19937 rng(7);
  int status_count = 0, segment_count = 0;
  const auto cases = measurement_cases();
  for (std::size_t k = 0; k < cases.size(); ++k) {
    std::array<CanFrame, 2> out{};
    const int n = encoder.encode_measurement(cases[k], out);
    EXPECT_EQ(n, 2);
    expect_measurement(expected, static_cast<int>(frames.size()), static_cast<int>(k % 15), cases[k]);
    const std::int64_t t = kT0 + static_cast<std::int64_t>(k) * 33'333'333;
    for (int i = 0; i < n; ++i) {
      EXPECT_TRUE(writer.write(out[static_cast<std::size_t>(i)], t + i * 150'000));
      frames.push_back(out[static_cast<std::size_t>(i)]);
      times.push_back(t + i * 150'000);
    }
    expect_conditions(expected, static_cast<int>(frames.size()), static_cast<int>(k % 15), cases[k]);
    frames.push_back(encoder.encode_conditions(cases[k]));
    times.push_back(t + n * 150'000);
    EXPECT_TRUE(writer.write(frames.back(), times.back()));
    if (k % 2 == 0) {  // a daemon with a speed or positioning source
      const MotionCase c = motion_case(rng, static_cast<int>(k / 2));
      expect_motion(expected, static_cast<int>(frames.size()), static_cast<int>(k % 15), c);
      frames.push_back(encoder.encode_motion(c.motion, c.position));
      times.push_back(t + (n + 1) * 150'000);
      EXPECT_TRUE(writer.write(frames.back(), times.back()));
    }
    if (k % 10 == 9) {
      const SensorHealth h = health_case(rng, status_count);
      expect_status(expected, static_cast<int>(frames.size()), status_count % 15, h);
      frames.push_back(encoder.encode_status(h));
      times.push_back(t + 1'000'000);
      EXPECT_TRUE(writer.write(frames.back(), times.back()));
      if (status_count % 2 == 0) {  // a daemon with an uplink
        const UplinkState u = uplink_case(rng, status_count / 2);
        expect_uplink(expected, static_cast<int>(frames.size()), (status_count / 2) % 15, u);
        frames.push_back(encoder.encode_uplink(u));
        times.push_back(t + 1'050'000);
        EXPECT_TRUE(writer.write(frames.back(), times.back()));
      }
      if (status_count % 3 == 0) {
        const int version_count = status_count / 3;
        const SoftwareVersion v = version_case(rng, version_count);
        expect_version(expected, static_cast<int>(frames.size()), version_count % 15, v);
        frames.push_back(encoder.encode_version(v));
        times.push_back(t + 1'100'000);
        EXPECT_TRUE(writer.write(frames.back(), times.back()));
      }
      ++status_count;
    }
    if (k % 5 == 4) {  // a segment closes
      std::array<CanFrame, 2> out{};
      const Segment g = segment_case(rng, segment_count);
      expect_segment(expected, static_cast<int>(frames.size()), segment_count % 15, g);
      EXPECT_EQ(encoder.encode_segment(g, out), 2);
      for (int i = 0; i < 2; ++i) {
        frames.push_back(out[static_cast<std::size_t>(i)]);
        times.push_back(t + 1'200'000 + i * 100'000);
        EXPECT_TRUE(writer.write(frames.back(), times.back()));
      }
      ++segment_count;
    }
  }
  return {expected, frames};
}

// ---------------------------------------------------------------------------------------------------

TEST(CanEncoder, DefaultIdentifiersAreJ1939ProprietaryB) {
  CanEncoder encoder;
  std::array<CanFrame, 2> out{};
  ASSERT_EQ(encoder.encode_measurement(RutMeasurement{}, out), 2);
  const CanFrame status = encoder.encode_status(SensorHealth{});
  EXPECT_EQ(out[0].id, 0x18FF50A0U);
  EXPECT_EQ(out[1].id, 0x18FF51A0U);
  EXPECT_EQ(status.id, 0x18FF52A0U);
  const CanFrame conditions = encoder.encode_conditions(RutMeasurement{});
  EXPECT_EQ(conditions.id, 0x18FF53A0U);
  const CanFrame version = encoder.encode_version(SoftwareVersion{});
  EXPECT_EQ(version.id, 0x18FF5FA0U);
  for (const CanFrame& f : {out[0], out[1], status, conditions, version}) {
    EXPECT_TRUE(f.extended);
    EXPECT_EQ(f.len, 8);
  }
}

TEST(CanEncoder, SourceAddressAndPriorityGoIntoTheIdentifier) {
  CanIdConfig ids;
  ids.source_address = 0x2B;
  ids.priority = 3;
  CanEncoder encoder(ids);
  // priority 3 -> bits 26..28 = 011; PGN 0xFF52; SA 0x2B.
  EXPECT_EQ(encoder.encode_status(SensorHealth{}).id, 0x0CFF522BU);
}

TEST(CanEncoder, ElevenBitIdentifiersCarryTheSamePayload) {
  CanIdConfig ids;
  ids.extended = false;
  CanEncoder standard(ids);
  CanEncoder extended;
  std::mt19937 rng(99);
  for (int k = 0; k < 20; ++k) {
    const RutMeasurement m = random_measurement(rng, k % 3 ? RutStatus::Ok : RutStatus::NoRut);
    std::array<CanFrame, 2> a{};
    std::array<CanFrame, 2> b{};
    standard.encode_measurement(m, a);
    extended.encode_measurement(m, b);
    EXPECT_EQ(a[0].id, 0x350U);
    EXPECT_EQ(a[1].id, 0x351U);
    EXPECT_FALSE(a[0].extended);
    EXPECT_EQ(a[0].data, b[0].data);
    EXPECT_EQ(a[1].data, b[1].data);
    const CanFrame ca = standard.encode_conditions(m), cb = extended.encode_conditions(m);
    EXPECT_EQ(ca.id, 0x353U);
    EXPECT_EQ(ca.data, cb.data);
  }
  SensorHealth h;
  h.frame_rate_hz = 30;
  const CanFrame s = standard.encode_status(h);
  EXPECT_EQ(s.id, 0x352U);
  EXPECT_EQ(s.data, extended.encode_status(h).data);
  const SoftwareVersion v{1, 2, 3, 4, 0x12345, true, false};
  const CanFrame version = standard.encode_version(v);
  EXPECT_EQ(version.id, 0x35FU);
  EXPECT_EQ(version.data, extended.encode_version(v).data);
}

// The worked example of can/can_encoder.hpp, byte for byte (bytes and CRC worked out by hand there).
TEST(CanEncoder, SegmentFrameIsTheWorkedExample) {
  CanEncoder encoder;
  Segment g;
  g.index = 12;
  g.start_m = 12;
  g.end_m = 13;
  g.frames = 10;
  g.mean_depth_mm = 85.0;
  g.p95_depth_mm = 93.4;
  g.worst_status = RutStatus::Ok;
  g.advisory = Advisory::Caution;
  std::array<CanFrame, 2> out{};
  encoder.encode_segment(g, out);
  EXPECT_EQ(out[0].id, 0x18FF54A0u);
  EXPECT_EQ(out[1].id, 0x18FF55A0u);
  const std::array<std::uint8_t, 7> want{0x20, 0x14, 0x05, 0x20, 0x35, 0xA6, 0x03};
  for (int i = 0; i < 7; ++i)
    EXPECT_EQ(out[0].data[static_cast<std::size_t>(i + 1)], want[static_cast<std::size_t>(i)]) << i;
}

TEST(CanEncoder, MotionFrameIsTheWorkedExample) {
  CanEncoder encoder;
  std::array<CanFrame, 2> out{};
  encoder.encode_measurement(RutMeasurement{}, out);  // counter 0
  VehicleMotion motion;
  motion.state = SpeedState::Ok;
  motion.speed_mm_s = 2000;  // 7.2 km/h
  motion.distance_m = 12.34;
  GeoFix fix;
  fix.mode = GeoFix::Mode::Fix3d;
  std::ostringstream os;
  CandumpLogWriter(os, "can0").write(encoder.encode_motion(motion, fix), 1'000'000);
  EXPECT_EQ(os.str(), "(0000000000.001000) can0 18FF56A0#9A00D07FD20400F3\n");
  CanIdConfig ids;
  ids.extended = false;
  CanEncoder standard(ids);
  standard.encode_measurement(RutMeasurement{}, out);
  const CanFrame eleven = standard.encode_motion(motion, fix);
  EXPECT_EQ(eleven.id, 0x356U);
  EXPECT_EQ(eleven.data, encoder.encode_motion(motion, fix).data);
}

TEST(CanEncoder, UplinkFrameIsTheWorkedExample) {
  CanEncoder encoder;
  UplinkState u;
  u.enabled = true;
  u.queued = 1234;
  u.oldest_unsent_s = 75;
  u.send_errors = true;
  std::ostringstream os;
  CandumpLogWriter(os, "can0").write(encoder.encode_uplink(u), 1'000'000);
  EXPECT_EQ(os.str(), "(0000000000.001000) can0 18FF57A0#9D00D204004B00F9\n");
}

TEST(CanEncoder, VersionFrameIsTheWorkedExample) {
  CanEncoder encoder;
  std::ostringstream os;
  CandumpLogWriter(os, "can0").write(encoder.encode_version({0, 1, 0, 1, 0xA5905, true, false}), 1'000'000);
  EXPECT_EQ(os.str(), "(0000000000.001000) can0 18FF5FA0#3B100001005090A5\n");
}

TEST(CanEncoder, RejectsUnusableIdentifiers) {
  auto with = [](auto change) {
    CanIdConfig ids;
    change(ids);
    return ids;
  };
  EXPECT_TRUE(check_can_id_config(CanIdConfig{}).empty());
  EXPECT_THROW(CanEncoder(with([](CanIdConfig& c) { c.priority = 8; })), std::invalid_argument);
  EXPECT_THROW(CanEncoder(with([](CanIdConfig& c) { c.source_address = 0xFE; })), std::invalid_argument);
  EXPECT_THROW(CanEncoder(with([](CanIdConfig& c) { c.status_pgn = 0xEF00; })), std::invalid_argument);  // PDU1
  EXPECT_THROW(CanEncoder(with([](CanIdConfig& c) { c.measurement1_pgn = 0x4FF50; })), std::invalid_argument);
  EXPECT_THROW(CanEncoder(with([](CanIdConfig& c) { c.measurement2_id_11bit = 0x800; })), std::invalid_argument);
  EXPECT_THROW(CanEncoder(with([](CanIdConfig& c) { c.version_pgn = 0xEA00; })), std::invalid_argument);  // PDU1
  EXPECT_THROW(CanEncoder(with([](CanIdConfig& c) { c.version_id_11bit = 0x800; })), std::invalid_argument);
  EXPECT_NE(check_can_id_config(with([](CanIdConfig& c) { c.priority = 9; })).find("priority"), std::string::npos);
}

TEST(CanEncoder, MeasurementFramesShareACounterThatRunsZeroToFourteen) {
  CanEncoder encoder;
  std::array<CanFrame, 2> out{};
  for (int k = 0; k < 40; ++k) {
    encoder.encode_measurement(RutMeasurement{}, out);
    EXPECT_EQ(out[0].data[1] & 0x0F, k % 15);
    EXPECT_EQ(out[1].data[1] & 0x0F, k % 15);
    EXPECT_EQ(encoder.encode_conditions(RutMeasurement{}).data[1] & 0x0F, k % 15);
    EXPECT_EQ(encoder.encode_motion(VehicleMotion{}, GeoFix{}).data[1] & 0x0F, k % 15);
  }
}

TEST(CandumpLog, FormatsLikeCandump) {
  std::ostringstream os;
  CandumpLogWriter writer(os, "can0");
  CanFrame ext{0x18FF50A0, true, 8, {0x01, 0x02, 0x03, 0x04, 0x05, 0x06, 0x07, 0x08}};
  CanFrame std11{0x350, false, 2, {0xA1, 0xB2}};
  CanFrame empty{0x123, false, 0, {}};
  CanFrame low{0x00000001, true, 1, {0xFF}};
  EXPECT_TRUE(writer.write(ext, 1'700'000'000'123'456'789));
  EXPECT_TRUE(writer.write(std11, 1'700'000'000'223'456'000));
  EXPECT_TRUE(writer.write(empty, 12'000'001'999));
  EXPECT_TRUE(writer.write(low, -5));
  EXPECT_EQ(os.str(),
            "(1700000000.123456) can0 18FF50A0#0102030405060708\n"
            "(1700000000.223456) can0 350#A1B2\n"
            "(0000000012.000001) can0 123#\n"
            "(0000000000.000000) can0 00000001#FF\n");
}

TEST(CandumpLog, ParsesWhatItWritesAndCandumpVariants) {
  std::mt19937 rng(5);
  for (int k = 0; k < 200; ++k) {
    CanFrame f;
    f.extended = k % 2 == 0;
    f.id = std::uniform_int_distribution<std::uint32_t>(0, f.extended ? 0x1FFFFFFF : 0x7FF)(rng);
    f.len = static_cast<std::uint8_t>(k % 9);
    for (int i = 0; i < f.len; ++i) f.data[static_cast<std::size_t>(i)] = static_cast<std::uint8_t>(rng());
    const std::int64_t t = std::uniform_int_distribution<std::int64_t>(0, 4'000'000'000'000'000'000)(rng);
    std::ostringstream os;
    CandumpLogWriter(os, "vcan12").write(f, t);
    const auto parsed = parse_candump_line(os.str());
    ASSERT_TRUE(parsed) << os.str();
    EXPECT_EQ(parsed->first, f) << os.str();
    EXPECT_EQ(parsed->second, t - t % 1000) << os.str();
  }
  const auto dotted = parse_candump_line("(1.000002) can1 12345678#de.ad.BE.ef  \r\n");
  ASSERT_TRUE(dotted);
  EXPECT_EQ(dotted->first, (CanFrame{0x12345678, true, 4, {0xDE, 0xAD, 0xBE, 0xEF}}));
  EXPECT_EQ(dotted->second, 1'000'002'000);
}

TEST(CandumpLog, RejectsWhatIsNotAClassicDataFrame) {
  for (const char* bad :
       {"", "(1.000000) can0", "1.000000 can0 123#00", "(1.00000) can0 123#00", "(1.000000) can0 123#R",
        "(1.000000) can0 123##0112233", "(1.000000) can0 1234#00", "(1.000000) can0 800#00",
        "(1.000000) can0 20000000#00", "(1.000000) can0 123#0", "(1.000000) can0 123#001122334455667788",
        "(1.000000) can0 12G#00", "(1.000000) can0 123#00 trailing", "(-1.000000) can0 123#00"}) {
    EXPECT_FALSE(parse_candump_line(bad)) << bad;
  }
}

TEST(CanDbc, CanmatrixDecodesEveryFrameToTheInputValues) {
  if (const std::string missing = decoder_unavailable(); !missing.empty()) RUTD_SKIP_NEEDS_INSTALLED(missing);
  const fs::path dir = make_temp_dir();
  const fs::path log = dir / "rutd.log";
  std::vector<std::int64_t> times;
  auto [expected, frames] = write_log(log, times);

  const DecoderRun run = run_decoder(log, dir);
  EXPECT_EQ(run.exit_code, 0) << run.diagnostics;
  EXPECT_NE(run.diagnostics.find("frames=" + std::to_string(frames.size()) +
                                 " crc_errors=0 counter_errors=0 "
                                 "unknown_frames=0 bad_lines=0"),
            std::string::npos)
      << run.diagnostics;

  std::size_t checked = 0;
  for (const DecodedSignal& row : run.rows) {
    ASSERT_LT(static_cast<std::size_t>(row.index), frames.size());
    EXPECT_EQ(row.t_ns, times[static_cast<std::size_t>(row.index)] / 1000 * 1000);
    if (row.signal.ends_with("_CRC")) {
      EXPECT_EQ(row.raw, frames[static_cast<std::size_t>(row.index)].data[0]);
      continue;
    }
    const auto it = expected.find({row.index, row.signal});
    if (it == expected.end()) {
      ADD_FAILURE() << "frame " << row.index << " " << row.message << ": unexpected signal " << row.signal;
      continue;
    }
    const Expect& e = it->second;
    const std::string where = "frame " + std::to_string(row.index) + " " + row.signal;
    if (e.na) {
      EXPECT_TRUE(row.na) << where << " should be not available, raw " << row.raw;
    } else {
      if (e.ranged) {
        EXPECT_FALSE(row.na) << where << " raw " << row.raw;
      }
      EXPECT_NEAR(row.phys, e.value, e.tolerance) << where;
      if (!e.named.empty()) {
        EXPECT_EQ(row.named, e.named) << where;
      }
    }
    expected.erase(it);
    ++checked;
  }
  EXPECT_TRUE(expected.empty()) << expected.size() << " expected signals were not decoded, first: frame "
                                << expected.begin()->first.first << " " << expected.begin()->first.second;
  std::printf("decoded %zu frames, checked %zu signal values against the inputs\n", frames.size(), checked);
  fs::remove_all(dir);
}

TEST(CanDbc, DecoderReportsCorruptionLossAndReordering) {
  if (const std::string missing = decoder_unavailable(); !missing.empty()) RUTD_SKIP_NEEDS_INSTALLED(missing);
  const fs::path dir = make_temp_dir();
  const fs::path log = dir / "bad.log";
  CanEncoder encoder;
  std::vector<std::array<CanFrame, 2>> measurements(6);
  for (auto& out : measurements) encoder.encode_measurement(ok_measurement(50, 200, 10, 12, 4000, 1, 0, 0.9), out);
  measurements[1][1].data[4] ^= 0x10;  // one bit flipped in a payload byte
  {
    std::ofstream os(log);
    CandumpLogWriter writer(os);
    std::int64_t t = kT0;
    auto put = [&](const CanFrame& f) { writer.write(f, t += 1'000'000); };
    put(measurements[0][0]), put(measurements[0][1]);  // log index 0, 1
    put(measurements[1][0]), put(measurements[1][1]);  // 2, 3: CRC error at 3
    /* measurement 2 lost entirely */
    put(measurements[3][0]), put(measurements[3][1]);  // 4: counter jumps from 1 to 3
    put(measurements[4][0]);                           // 6: partner missing ...
    put(measurements[5][0]), put(measurements[5][1]);  // 7: ... noticed here
  }
  const DecoderRun run = run_decoder(log, dir);
  EXPECT_NE(run.exit_code, 0);
  EXPECT_NE(run.diagnostics.find("CRC_ERROR index=3 "), std::string::npos) << run.diagnostics;
  EXPECT_NE(run.diagnostics.find("COUNTER_ERROR index=4 "), std::string::npos) << run.diagnostics;
  EXPECT_NE(run.diagnostics.find("COUNTER_ERROR index=7 "), std::string::npos) << run.diagnostics;
  EXPECT_NE(run.diagnostics.find("crc_errors=1 counter_errors=2 "), std::string::npos) << run.diagnostics;
  fs::remove_all(dir);
}

TEST(CandumpLog, Log2ascConvertsEveryFrame) {
  if (!fs::exists("/usr/bin/log2asc") && run_shell("command -v log2asc >/dev/null 2>&1") != 0) {
    RUTD_SKIP_NEEDS_INSTALLED("log2asc (Debian package can-utils) is needed");
  }
  const fs::path dir = make_temp_dir();
  const fs::path log = dir / "rutd.log";
  const fs::path asc = dir / "rutd.asc";
  std::vector<std::int64_t> times;
  const auto frames = write_log(log, times).second;
  ASSERT_EQ(run_shell("log2asc -I " + quoted(log) + " -O " + quoted(asc) + " can0"), 0);

  // ASC frame lines: "<seconds since first> 1  <ID>[x]  Rx   d <len> <bytes...>".
  std::ifstream in(asc);
  std::string line;
  std::size_t n = 0;
  while (std::getline(in, line)) {
    std::istringstream ss(line);
    double t = 0;
    std::string channel, id, dir_text, kind;
    int len = -1;
    if (!(ss >> t >> channel >> id >> dir_text >> kind >> len) || kind != "d") continue;
    ASSERT_LT(n, frames.size()) << line;
    const CanFrame& f = frames[n];
    char want_id[16];
    std::snprintf(want_id, sizeof want_id, f.extended ? "%08Xx" : "%03X", f.id);
    EXPECT_EQ(id, want_id) << line;
    EXPECT_EQ(len, f.len) << line;
    for (int i = 0; i < len; ++i) {
      std::string byte;
      ss >> byte;
      EXPECT_EQ(std::stoi(byte, nullptr, 16), f.data[static_cast<std::size_t>(i)]) << line;
    }
    EXPECT_NEAR(t, static_cast<double>(times[n] / 1000 - times[0] / 1000) * 1e-6, 1.5e-6) << line;
    ++n;
  }
  EXPECT_EQ(n, frames.size());
  fs::remove_all(dir);
}

}  // namespace
}  // namespace rutd
