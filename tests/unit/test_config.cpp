// The configuration file: the embedded default loads, and every kind of bad input gets one error that
// names the file, the line and the key.
#include <fstream>
#include <sstream>

#include <gtest/gtest.h>

#include "core/input_error.hpp"
#include "daemon/config.hpp"
#include "daemon/run_sources.hpp"
#include "synthetic/synthetic_renderer.hpp"
#include "test_support.hpp"

namespace rutd {
namespace {

// Expects parse_config to throw an InputError whose message contains every one of `parts`.
void expect_error(const std::string& yaml, std::initializer_list<std::string> parts) {
  try {
    parse_config(yaml, "test.yaml");
    ADD_FAILURE() << "no error for:\n" << yaml;
  } catch (const InputError& e) {
    const std::string what = e.what();
    EXPECT_EQ(e.file(), "test.yaml");
    for (const auto& part : parts) EXPECT_NE(what.find(part), std::string::npos) << "'" << part << "' not in: " << what;
  }
}

TEST(Config, EmbeddedDefaultIsTheSyntheticBenchOnStdout) {
  const RutdConfig c = parse_config(default_config_text(), "(embedded default)");
  EXPECT_EQ(c.source, SourceKind::Synthetic);
  EXPECT_EQ(c.sinks.candump, "-");
  EXPECT_TRUE(c.sinks.socketcan.empty());
  EXPECT_TRUE(c.measurement.dic);
  EXPECT_TRUE(c.can.extended);
  EXPECT_EQ(c.can.source_address, 0xA0);
  EXPECT_EQ(c.synthetic.rig.image_size, cv::Size(640, 480));
  EXPECT_EQ(c.synthetic_cycle_frames, 8);
}

// Every value the configuration can set, one "key=value" line each, for comparing two configurations.
std::string dump(const RutdConfig& c) {
  std::ostringstream o;
  const SyntheticRendererConfig& y = c.synthetic;
  o << "source=" << static_cast<int>(c.source) << "\nsize=" << y.rig.image_size << "\nfps=" << y.fps
    << "\nbaseline=" << y.rig.baseline_mm << "\nheight=" << y.rig.height_mm << "\nroll=" << y.rig.roll_deg
    << "\npitch=" << y.rig.pitch_deg << "\nhfov=" << y.rig.hfov_deg << "\ntexture=" << static_cast<int>(y.texture)
    << "\ndepth=" << y.rut.depth_mm << "\nwidth=" << y.rut.width_mm << "\nbottom=" << y.rut.bottom_width_mm
    << "\npiles=" << y.rut.pile_left_mm << "," << y.rut.pile_right_mm << "," << y.rut.pile_width_mm
    << "\nwander=" << y.rut.wander_amplitude_mm << "\nspeed=" << y.speed_mm_s << "\nnoise=" << y.noise_sigma
    << "\nseed=" << y.seed << "\ncycle_frames=" << c.synthetic_cycle_frames;
  o << "\nreplay=" << c.replay.dir << "," << c.replay.paced << "," << c.replay.loop << "\nrecord=" << c.record << ","
    << c.record_buffer;
  const AravisSourceConfig& a = c.aravis;
  const auto region = [](const SensorRegion& r) {
    return std::to_string(r.x) + "," + std::to_string(r.y) + "," + std::to_string(r.width) + "," +
           std::to_string(r.height);
  };
  o << "\naravis=" << a.left << "," << a.right << "," << static_cast<int>(a.pixel_format) << "," << region(a.roi) << ","
    << a.binning << "," << a.fps << "," << static_cast<int>(a.sync) << "," << a.trigger_line << "," << a.exposure_auto
    << "," << a.exposure_us << "," << a.exposure_min_us << "," << a.exposure_max_us << "," << a.gain_auto << ","
    << a.gain_db << "," << a.gain_max_db << "," << region(a.metering_region) << "," << a.pairing_window_ms << ","
    << a.stall_timeout_ms << "," << a.reconnect_min_ms << "," << a.reconnect_max_ms << "," << a.buffers << ","
    << a.packet_size << "," << a.packet_delay_ns << "," << a.socket_buffer_bytes << "," << a.packet_resend << ","
    << a.packet_socket;
  const MeasurerConfig& m = c.measurement;
  o << "\ncalibration=" << c.calibration << "\nengine=" << static_cast<int>(m.engine)
    << "\ngpu_device=" << m.engine_config.gpu_device << "\nsgm_paths=" << m.engine_config.sgm_paths
    << "\nsgm_segment=" << m.engine_config.sgm_segment << "\ndic=" << m.dic << "," << m.gap_fill_half_window
    << "\nstrip=" << m.strip.rows << "," << m.strip.first_row.value_or(-1) << "," << m.strip.guards << ","
    << m.strip.guard_spacing << "," << m.strip.guards_always << "," << m.strip.guard_after_water_s << ","
    << m.strip.frames_together_s << "\nrange=" << m.range.near_mm << "," << m.range.far_mm
    << "\nrut=" << m.rut.min_rut_width_mm << "," << m.rut.max_rut_width_mm << "," << m.rut.fit_window_mm << ","
    << m.rut.bin_mm << "," << m.rut.min_rut_depth_mm;
  o << "\ncan=" << c.can.extended << "," << int(c.can.source_address) << "," << int(c.can.priority);
  o << "\nsinks=" << c.sinks.socketcan << "," << c.sinks.candump << "," << c.sinks.can_interface_name << ","
    << c.sinks.csv;
  o << "\npipeline=" << c.pipeline.max_frame_age.count() << "," << c.pipeline.status_period.count();
  for (const ThreadPlacement& t : c.pipeline.threads) o << "," << t.cpu << "/" << t.fifo_priority;
  const PlotConfig& p = c.sinks.plots;
  o << "\nplots=" << c.sinks.plots_enabled << "," << p.dir << "," << p.every << "," << p.min_interval_s << ","
    << p.queue << "," << p.series_period_s;
  o << "\nlogging=" << c.logging.level << "," << c.logging.stats_period_s << "\n";
  o << "gps=" << c.gps.enabled << "," << c.gps.host << "," << c.gps.port << "," << c.gps.max_fix_age_ms << ","
    << c.gps.reconnect_min_ms << "," << c.gps.reconnect_max_ms << "," << c.gps.time_jump_s << ","
    << c.sinks.csv_positions << "\n";
  return o.str();
}

// config/rutd.yaml documents every key with its default. The independent truth for those defaults is the
// code: the structs' own initialisers, which an empty file leaves untouched. The shipped file must state
// exactly them, but for the one value it sets on purpose (a cycle of pre-rendered pairs, so that the
// default run costs a camera's CPU, not a renderer's). And the text `rutd run` embeds must be the file,
// byte for byte.
TEST(Config, ShippedFileStatesTheCodeDefaults) {
  const std::string path = std::string(RUTD_SOURCE_DIR) + "/config/rutd.yaml";
  std::ifstream in(path, std::ios::binary);
  const std::string text((std::istreambuf_iterator<char>(in)), {});
  ASSERT_FALSE(text.empty()) << path;
  RutdConfig code = parse_config("{}", "empty.yaml");
  EXPECT_EQ(code.synthetic_cycle_frames, 0);
  code.synthetic_cycle_frames = 8;
  code.file = path;
  EXPECT_EQ(dump(parse_config(text, path)), dump(code));
  EXPECT_EQ(text.size(), default_config_text().size());
  EXPECT_TRUE(text == default_config_text()) << "the embedded default is not config/rutd.yaml";
}

// What `cmake --install` puts in /etc/rutd: the default, but the cameras and their calibration as the
// source, CAN frames to can0 instead of stdout (which the journal would keep, a line per frame) and one
// summary a minute.
TEST(Config, InstalledFileSendsOnCanAndLogsSummaries) {
  // As installed it refuses to start until the integrator names the cameras, saying which key to set.
  try {
    load_config(RUTD_INSTALLED_CONFIG);
    ADD_FAILURE() << "the installed configuration started without cameras";
  } catch (const std::exception& e) {
    EXPECT_NE(std::string(e.what()).find("source.aravis.left"), std::string::npos) << e.what();
  }
  std::ifstream in(RUTD_INSTALLED_CONFIG);
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  for (const std::string key : {"left", "right"}) {
    const std::string empty = "    " + key + ": \"\"";
    const auto at = text.find(empty);
    ASSERT_NE(at, std::string::npos) << key;
    text.replace(at, empty.size(), "    " + key + ": cam-" + key);
  }
  const RutdConfig vehicle = parse_config(text, RUTD_INSTALLED_CONFIG);
  const RutdConfig bench = parse_config(default_config_text(), "(embedded default)");
  EXPECT_EQ(vehicle.sinks.socketcan, "can0");
  EXPECT_TRUE(vehicle.sinks.candump.empty());
  EXPECT_EQ(vehicle.logging.stats_period_s, 60);
  EXPECT_EQ(vehicle.logging.level, "info");
  // Only cameras are measured on a vehicle: the synthetic bench never reaches its bus by default.
  EXPECT_EQ(bench.source, SourceKind::Synthetic);
  EXPECT_EQ(vehicle.source, SourceKind::Aravis);
  EXPECT_EQ(vehicle.calibration, "/etc/rutd/calibration.yaml");
  EXPECT_EQ(vehicle.measurement.engine, bench.measurement.engine);
  EXPECT_EQ(vehicle.pipeline.status_period, bench.pipeline.status_period);
  EXPECT_EQ(vehicle.can.source_address, bench.can.source_address);
}

TEST(Config, ValuesAreRead) {
  const RutdConfig c = parse_config(
      "source:\n  type: replay\n  replay:\n    dir: /data/run1\n    loop: true\n"
      "measurement:\n  engine: hh\n  dic: false\n  strip:\n    rows: 32\n"
      "can:\n  id_format: 11bit\n  source_address: 0x42\n"
      "rut:\n  min_width_mm: 100\n  max_width_mm: 300\n"
      "pipeline:\n  cpu_affinity: [0, 1]\n",
      "test.yaml");
  EXPECT_EQ(c.source, SourceKind::Replay);
  EXPECT_EQ(c.replay.dir, "/data/run1");
  EXPECT_TRUE(c.replay.loop);
  EXPECT_EQ(c.measurement.engine, EngineKind::Hh);
  EXPECT_FALSE(c.measurement.dic);
  EXPECT_EQ(c.measurement.strip.rows, 32);
  EXPECT_FALSE(c.measurement.strip.first_row) << "centred";
  EXPECT_FALSE(c.can.extended);
  EXPECT_EQ(c.can.source_address, 0x42);
  EXPECT_EQ(c.measurement.rut.min_rut_width_mm, 100);
  EXPECT_EQ(c.pipeline.threads[0].cpu, 0);  // cpu_affinity: [0, 1]
  EXPECT_EQ(c.pipeline.threads[1].cpu, 1);
  EXPECT_EQ(c.pipeline.threads[2].cpu, -1);
}

TEST(Config, GpuEngineAndDeviceAreRead) {
  const RutdConfig c = parse_config(
      "measurement:\n  engine: gpu\n  gpu_device: \"NVIDIA\"\n  sgm_paths: 4\n  sgm_segment: 64\n", "test.yaml");
  EXPECT_EQ(c.measurement.engine, EngineKind::Gpu);
  EXPECT_EQ(c.measurement.engine_config.gpu_device, "NVIDIA");
  EXPECT_EQ(c.measurement.engine_config.sgm_paths, 4);
  EXPECT_EQ(c.measurement.engine_config.sgm_segment, 64);
  expect_error("measurement:\n  sgm_paths: 3\n", {"line 2", "measurement.sgm_paths", "2, 4 or 8"});
  expect_error("measurement:\n  sgm_segment: 8\n", {"line 2", "measurement.sgm_segment", "16..65535"});
}

TEST(Config, GapFillWindowIsReadAndBounded) {
  EXPECT_EQ(parse_config("measurement:\n  dic: true\n", "test.yaml").measurement.gap_fill_half_window, 11);
  EXPECT_EQ(parse_config("measurement:\n  gap_fill_half_window: 0\n", "test.yaml").measurement.gap_fill_half_window, 0);
  EXPECT_EQ(parse_config("measurement:\n  gap_fill_half_window: 15\n", "test.yaml").measurement.gap_fill_half_window,
            15);
  // No wider than the narrow windows (5 px) it reads again, and no wider than the DIC's 15 px.
  expect_error("measurement:\n  gap_fill_half_window: 5\n",
               {"line 2", "measurement.gap_fill_half_window", "0 (off) or 6..15", "got 5"});
  expect_error("measurement:\n  gap_fill_half_window: 16\n", {"line 2", "measurement.gap_fill_half_window", "got 16"});
}

TEST(Config, UnknownKeyIsNamedWithItsLine) {
  expect_error("measurement:\n  engine: sgbm\n  engnie: hh\n",
               {"test.yaml", "line 3", "measurement.engnie", "unknown key"});
  expect_error("sorce:\n  type: synthetic\n", {"line 1", "sorce", "unknown key"});
}

TEST(Config, WrongTypeIsNamed) {
  expect_error("measurement:\n  dic: maybe\n", {"line 2", "measurement.dic", "true or false", "maybe"});
  expect_error("pipeline:\n  max_frame_age_ms: soon\n", {"line 2", "pipeline.max_frame_age_ms", "a number"});
  expect_error("measurement: [1, 2]\n", {"measurement", "mapping"});
  expect_error("pipeline:\n  cpu_affinity: [0, x]\n", {"pipeline.cpu_affinity", "integer"});
}

TEST(Config, RecordingTeeIsOffByDefaultAndReadAsText) {
  EXPECT_TRUE(parse_config(default_config_text(), "(embedded default)").record.empty());
  EXPECT_EQ(parse_config("source:\n  record: /data/rec1\n", "test.yaml").record, "/data/rec1");
  expect_error("source:\n  record: [a, b]\n", {"line 2", "source.record", "expected text"});
  expect_error("source:\n  record:\n    dir: x\n", {"source.record", "expected text"});
  EXPECT_EQ(parse_config("source:\n  record_buffer: 120\n", "test.yaml").record_buffer, 120);
  expect_error("source:\n  record_buffer: 0\n", {"test.yaml", "line 2", "source.record_buffer"});
  expect_error("source:\n  record_buffer: 2000\n", {"test.yaml", "line 2", "source.record_buffer"});
}

TEST(Config, PlotsAreOffByDefaultAndNeedAFolder) {
  const RutdConfig d = parse_config(default_config_text(), "(embedded default)");
  EXPECT_FALSE(d.sinks.plots_enabled);
  const RutdConfig c = parse_config(
      "sinks:\n  plots:\n    enabled: true\n    dir: /tmp/p\n    every: 30\n    min_interval_s: 2\n"
      "    queue: 2\n    series_period_s: 0\n",
      "test.yaml");
  EXPECT_TRUE(c.sinks.plots_enabled);
  EXPECT_EQ(c.sinks.plots.dir, "/tmp/p");
  EXPECT_EQ(c.sinks.plots.every, 30u);
  EXPECT_EQ(c.sinks.plots.min_interval_s, 2.0);
  EXPECT_EQ(c.sinks.plots.queue, 2u);
  EXPECT_EQ(c.sinks.plots.series_period_s, 0.0);
  EXPECT_FALSE(c.sinks.plots.lossless);  // a live run drops plots, never measurements
  expect_error("sinks:\n  plots:\n    enabled: true\n", {"sinks.plots.dir", "must name a folder"});
  expect_error("sinks:\n  plots:\n    queue: 0\n", {"line 3", "sinks.plots.queue"});
}

TEST(Config, StripIsCentredUnlessItsFirstRowIsGiven) {
  const MeasurerConfig centred = parse_config("measurement:\n  strip:\n    rows: 40\n", "test.yaml").measurement;
  EXPECT_EQ(centred.strip.rows, 40);
  EXPECT_FALSE(centred.strip.first_row);
  const MeasurerConfig placed =
      parse_config("measurement:\n  strip:\n    rows: 40\n    first_row: 120\n", "test.yaml").measurement;
  ASSERT_TRUE(placed.strip.first_row);
  EXPECT_EQ(*placed.strip.first_row, 120);
  EXPECT_FALSE(parse_config("measurement:\n  strip:\n    rows: 40\n    first_row: centred\n", "test.yaml")
                   .measurement.strip.first_row);
  expect_error("measurement:\n  strip:\n    first_row: 10\n", {"line 3", "measurement.strip.first_row", "rows"});
  expect_error("measurement:\n  strip:\n    rows: 40\n    first_row: middle\n",
               {"line 4", "measurement.strip.first_row", "centred or a row number", "middle"});
  // The old spelling of centred is refused, saying the new one.
  expect_error("measurement:\n  strip:\n    rows: 40\n    first_row: -1\n",
               {"line 4", "measurement.strip.first_row", "now written centred"});
}

TEST(Config, GuardStripsAndTheirSpacing) {
  const MeasurerConfig defaults = parse_config("measurement:\n  strip:\n    rows: 40\n", "test.yaml").measurement;
  EXPECT_EQ(defaults.strip.guards, 2);
  EXPECT_DOUBLE_EQ(defaults.strip.guard_spacing, 0.25);
  EXPECT_FALSE(defaults.strip.guards_always);
  EXPECT_DOUBLE_EQ(defaults.strip.guard_after_water_s, 0.5);
  EXPECT_DOUBLE_EQ(defaults.strip.frames_together_s, 0.2);
  const MeasurerConfig set = parse_config(
                                 "measurement:\n  strip:\n    guards: 1\n    guard_spacing: 0.3\n"
                                 "    guards_always: true\n    guard_after_water_s: 2.5\n    frames_together_s: 0\n",
                                 "test.yaml")
                                 .measurement;
  EXPECT_EQ(set.strip.guards, 1);
  EXPECT_DOUBLE_EQ(set.strip.guard_spacing, 0.3);
  EXPECT_TRUE(set.strip.guards_always);
  EXPECT_DOUBLE_EQ(set.strip.guard_after_water_s, 2.5);
  EXPECT_DOUBLE_EQ(set.strip.frames_together_s, 0.0);
  EXPECT_EQ(parse_config("measurement:\n  strip:\n    guards: 0\n", "test.yaml").measurement.strip.guards, 0);
  expect_error("measurement:\n  strip:\n    guards: 3\n", {"test.yaml", "line 3", "measurement.strip.guards"});
  expect_error("measurement:\n  strip:\n    guard_spacing: 0.6\n",
               {"test.yaml", "line 3", "measurement.strip.guard_spacing"});
  expect_error("measurement:\n  strip:\n    guard_after_water_s: -1\n",
               {"test.yaml", "line 3", "measurement.strip.guard_after_water_s"});
  expect_error("measurement:\n  strip:\n    guards_always: often\n",
               {"test.yaml", "line 3", "measurement.strip.guards_always"});
  expect_error("measurement:\n  strip:\n    frames_together_s: 3\n",
               {"test.yaml", "line 3", "measurement.strip.frames_together_s"});
}

// A file written for an older release: each moved key is refused with one error naming the file, the
// line, the old key and the key that replaced it, never half-read.
TEST(Config, MovedKeysAreRefusedNamingTheirNewPlace) {
  expect_error("sinks:\n  csv: m.csv\n  record: /data/rec1\n",
               {"test.yaml", "line 3", "sinks.record", "moved: now source.record"});
  expect_error("source:\n  type: synthetic\nplots:\n  enabled: true\n  dir: /tmp/p\n",
               {"test.yaml", "line 3", "plots", "moved: now sinks.plots"});
  expect_error("measurement:\n  engine: hh\n  strip_rows: 32\n",
               {"test.yaml", "line 3", "measurement.strip_rows", "moved: now measurement.strip.rows"});
  expect_error("measurement:\n  strip_row0: -1\n",
               {"test.yaml", "line 2", "measurement.strip_row0", "moved: now measurement.strip.first_row", "centred"});
}

TEST(Config, ImpossibleValuesAreNamed) {
  expect_error("measurement:\n  near_mm: 900\n  far_mm: 400\n", {"measurement.near_mm", "smaller than far_mm"});
  expect_error("measurement:\n  engine: cuda9\n", {"line 2", "measurement.engine", "cuda9"});
  expect_error("rut:\n  min_width_mm: 500\n  max_width_mm: 300\n", {"rut.min_width_mm"});
  expect_error("can:\n  source_address: 0x1FF\n", {"line 2", "can.source_address"});
  expect_error("can:\n  priority: 9\n", {"can.priority"});
  expect_error("source:\n  synthetic:\n    size: 640by480\n", {"line 3", "source.synthetic.size", "640by480"});
  expect_error("source:\n  synthetic:\n    fps: -3\n", {"source.synthetic.fps", "between"});
  expect_error("source:\n  synthetic:\n    cycle_frames: -1\n", {"line 3", "source.synthetic.cycle_frames", "between"});
  expect_error("logging:\n  level: chatty\n", {"logging.level", "chatty"});
}

// Found by fuzzing: a key that is a list or a mapping made yaml-cpp throw YAML::BadConversion past every
// caller; and a value quoting a line break gave a two-line error.
TEST(Config, OddKeysAndLineBreaksGiveOneLineErrors) {
  expect_error("? [a, b]\n: 1\n", {"test.yaml: line 1, (top level): a key must be a plain name, got '[a, b]'"});
  expect_error("pipeline:\n  ? {x: 1}\n  : 2\n", {"line 2, pipeline: a key must be a plain name"});
  try {
    parse_config("measurement:\n  engine: \"cu\\nda\"\n", "test.yaml");
    ADD_FAILURE() << "no error";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()),
              "test.yaml: line 2, measurement.engine: expected bm, sgbm, sgbm3way, hh4, hh, gpu or sgmref, got "
              "'cu\\nda'");
  }
}

TEST(Config, MissingCalibrationAndFolderAreNamed) {
  expect_error("source:\n  type: aravis\n", {"calibration", "calibration file"});
  expect_error("source:\n  type: replay\n", {"source.replay.dir", "recording folder"});
  expect_error("source:\n  type: webcam\n", {"line 2", "source.type", "webcam"});
}

TEST(Config, CameraSectionIsReadAndChecked) {
  const RutdConfig c = parse_config(
      "source:\n  type: aravis\n  aravis:\n    left: GV01\n    right: 192.168.3.20\n    pixel_format: bayer\n"
      "    roi: [8, 16, 1280, 1024]\n    binning: 2\n    fps: 40\n    sync: software_trigger\n"
      "    exposure_auto: true\n    metering_region: [0, 512, 1280, 512]\n    packet_size: 9000\n"
      "    packet_socket: true\n"
      "calibration: rig.yaml\n",
      "test.yaml");
  EXPECT_EQ(c.source, SourceKind::Aravis);
  EXPECT_EQ(c.aravis.left, "GV01");
  EXPECT_EQ(c.aravis.right, "192.168.3.20");
  EXPECT_EQ(c.aravis.pixel_format, CameraPixelFormat::Bayer8);
  EXPECT_EQ(c.aravis.roi.x, 8);
  EXPECT_EQ(c.aravis.roi.height, 1024);
  EXPECT_EQ(c.aravis.binning, 2);
  EXPECT_EQ(c.aravis.sync, CameraSync::SoftwareTrigger);
  EXPECT_TRUE(c.aravis.exposure_auto);
  EXPECT_EQ(c.aravis.metering_region.y, 512);
  EXPECT_EQ(c.aravis.packet_size, 9000);
  EXPECT_TRUE(c.aravis.packet_socket);

  const std::string cams = "source:\n  type: aravis\n  aravis:\n    left: A\n    right: B\n";
  EXPECT_FALSE(parse_config(cams + "calibration: r.yaml\n", "test.yaml").aravis.packet_socket) << "off by default";
  expect_error(cams + "calibration: rig.yaml\n" + "x: 1\n", {"x", "unknown key"});
  expect_error("source:\n  type: aravis\ncalibration: rig.yaml\n", {"source.aravis.left", "left camera"});
  expect_error("source:\n  type: aravis\n  aravis:\n    left: A\n    right: A\ncalibration: r.yaml\n",
               {"source.aravis.right", "same camera"});
  expect_error(cams + "    sync: genlock\ncalibration: r.yaml\n", {"line 6", "source.aravis.sync", "genlock"});
  expect_error(cams + "    roi: [0, 0, 640]\ncalibration: r.yaml\n",
               {"line 6", "source.aravis.roi", "[x, y, width, height]"});
  expect_error(cams + "    roi: [0, 0, 640, 0]\ncalibration: r.yaml\n", {"source.aravis.roi", "both"});
  expect_error(cams + "    fps: 100\n    pairing_window_ms: 6\ncalibration: r.yaml\n",
               {"line 7", "source.aravis.pairing_window_ms", "half the frame period"});
  expect_error(cams + "    stall_timeout_ms: 10\ncalibration: r.yaml\n",
               {"source.aravis.stall_timeout_ms", "frame period"});
  expect_error(cams + "    packet_size: 100\ncalibration: r.yaml\n", {"source.aravis.packet_size", "576"});
  expect_error(cams + "    buffers: many\ncalibration: r.yaml\n", {"source.aravis.buffers", "an integer"});
}

TEST(Config, BrokenYamlAndMissingFileAreNamed) {
  expect_error("measurement:\n  engine: [sgbm\n", {"test.yaml", "line", "not valid YAML"});
  try {
    load_config("/nonexistent/rutd.yaml");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent/rutd.yaml"), std::string::npos);
  }
}

// The embedded default's synthetic source plays a cycle rendered once: pair k is the renderer's pair
// k mod cycle_frames, pixel for pixel, stamped like a live camera.
TEST(RunSources, SyntheticCycleReplaysTheRenderedPairs) {
  RutdConfig c =
      parse_config("source:\n  synthetic:\n    size: 320x240\n    fps: 200\n    cycle_frames: 3\n", "test.yaml");
  const std::unique_ptr<FrameSource> source = make_source(c);
  const SyntheticRenderer renderer(c.synthetic);
  std::int64_t last_t = 0;
  for (std::uint64_t k = 0; k < 5; ++k) {
    StereoFrame got, want;
    ASSERT_EQ(source->next(got), SourceStatus::Ok);
    renderer.render(k % 3, want);
    EXPECT_EQ(got.seq, k);
    EXPECT_EQ(cv::norm(got.left, want.left, cv::NORM_INF), 0.0) << "pair " << k;
    EXPECT_EQ(cv::norm(got.right, want.right, cv::NORM_INF), 0.0) << "pair " << k;
    EXPECT_EQ(got.clock, ClockKind::Monotonic);
    EXPECT_GT(got.t_ns, last_t);
    last_t = got.t_ns;
  }
  EXPECT_EQ(source->calibration().image_size, cv::Size(320, 240));
}

}  // namespace
}  // namespace rutd

namespace rutd {
namespace {

TEST(Config, TrafficabilityIsReadAndCheckedNamingTheKey) {
  const RutdConfig d = parse_config(default_config_text(), "(embedded default)");
  EXPECT_TRUE(d.trafficability.socketcan.empty());
  EXPECT_EQ(d.trafficability.segments.length_m, 1.0);
  ASSERT_EQ(d.trafficability.segments.damage.size(), 3u);
  EXPECT_EQ(d.trafficability.segments.damage[2].min_length_m, 4.0);
  EXPECT_EQ(d.trafficability.segments.damage[2].max_share, 0.25);
  const RutdConfig c = parse_config(
      "trafficability:\n  speed: {socketcan: can1, source_address: 0x0B, direction_from_gear: true, max_age_ms: 200}\n"
      "  segment_length_m: 0.5\n  advisory: {caution_depth_mm: 60, no_go_depth_mm: 100, hysteresis_m: 2}\n"
      "  soil: {source: 'test lane 2024', table: [[0, 900], [100, 300]], vehicle_limit_one_pass: 400}\n",
      "t.yaml");
  EXPECT_EQ(c.trafficability.socketcan, "can1");
  EXPECT_EQ(c.trafficability.speed.source_address, 0x0B);
  EXPECT_TRUE(c.trafficability.speed.direction_from_gear);
  EXPECT_EQ(c.trafficability.odometer.max_age_ns, 200'000'000);
  EXPECT_EQ(c.trafficability.segments.length_m, 0.5);
  EXPECT_EQ(c.trafficability.segments.advisory.no_go_depth_mm, 100);
  ASSERT_EQ(c.trafficability.segments.soil.table.size(), 2u);
  EXPECT_EQ(c.trafficability.segments.soil.limit_one_pass, 400);
  expect_error("trafficability:\n  speed: {source_address: 0xFE}\n", {"line 2", "trafficability.speed.source_address"});
  expect_error("trafficability:\n  speed: {message: dbc}\n", {"trafficability.speed.message", "dbc_signal"});
  expect_error("trafficability:\n  speed: {message: dbc, dbc: /nonexistent.dbc, dbc_message: A, dbc_signal: B}\n",
               {"trafficability.speed.dbc", "/nonexistent.dbc"});
  expect_error("trafficability:\n  advisory: {caution_depth_mm: 90, no_go_depth_mm: 50}\n",
               {"trafficability.advisory.no_go_depth_mm"});
  expect_error("trafficability:\n  soil: {source: x, table: [[0, 100], [10, 200]]}\n",
               {"trafficability.soil.table", "table[1]"});
  expect_error("trafficability:\n  soil: {table: [[0, 100], [10, 50]]}\n", {"trafficability.soil", "source"});
  expect_error("trafficability:\n  damage: [{name: x, depth_mm: 100, min_lenght_m: 1}]\n",
               {"trafficability.damage[0].min_lenght_m", "unknown key"});
  expect_error("trafficability:\n  segment_length_m: 0\n", {"trafficability.segment_length_m"});
}

TEST(ConfigGps, OffByDefaultAndReadWhenGiven) {
  const RutdConfig d = parse_config(default_config_text(), "(embedded default)");
  EXPECT_FALSE(d.gps.enabled);
  EXPECT_FALSE(d.sinks.csv_positions);
  const RutdConfig c = parse_config(
      "gps:\n  enabled: true\n  host: gnss.local\n  port: \"2948\"\n  max_fix_age_ms: 800\n"
      "sinks:\n  csv_positions: true\n",
      "test.yaml");
  EXPECT_TRUE(c.gps.enabled);
  EXPECT_EQ(c.gps.host, "gnss.local");
  EXPECT_EQ(c.gps.port, "2948");
  EXPECT_DOUBLE_EQ(c.gps.max_fix_age_ms, 800.0);
  EXPECT_TRUE(c.sinks.csv_positions);
}

TEST(ConfigGps, BadValuesNameTheFileAndKey) {
  expect_error("gps:\n  port: \"http\"\n", {"line 2", "gps.port", "1..65535"});
  expect_error("gps:\n  max_fix_age_ms: 0\n", {"line 2", "gps.max_fix_age_ms", "between"});
  expect_error("gps:\n  reconnect_min_ms: 900\n  reconnect_max_ms: 100\n", {"gps.reconnect_min_ms"});
  expect_error("gps:\n  enabld: true\n", {"line 2", "gps.enabld", "unknown key"});
  expect_error("sinks:\n  csv_positions: true\n", {"line 2", "sinks.csv_positions", "gps.enabled"});
}

}  // namespace
}  // namespace rutd
