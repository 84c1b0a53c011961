// rutd bench: end-to-end rate and latency of the real-time pipeline with the real measurer on synthetic
// pairs, in strip mode (the default measured strip) and full-frame mode (every row measured). A few pairs
// are rendered up front and cycled through an in-memory source that copies them into the slot buffers,
// so rendering is not measured. Two regimes per mode:
//   throughput  lossless, the source as fast as the pipeline takes pairs: the sustained rate;
//   live        freshest frame wins, the source paced like a camera (--fps): capture-to-publish latency.
// Figures are printed, never asserted: compare ratios within one run on a shared machine. --json prints
// the same rows as one JSON object per line (for scripts and tables), instead of the text.
#include <sys/resource.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include <fmt/format.h>

#include "daemon/bench_scenes.hpp"
#include "daemon/bench_tables.hpp"
#include "daemon/commands.hpp"
#include "daemon/dimensions.hpp"
#include "runtime/realtime_pipeline.hpp"
#include "synthetic/cycling_source.hpp"
#include "synthetic/synthetic_renderer.hpp"

namespace rutd {
namespace {

struct Options {
  double seconds = 5;  // per run
  double fps = 30;     // live regime's camera rate
  bool dic = true;
  int frames = 4;  // distinct pairs rendered
  std::string engine = "sgbm3way";
  std::string size = "640x480";
  bool json = false;
  int guards = StripConfig{}.guards;  // guard strips of the strip runs (StripConfig::guards)
  bool guards_always = false;         // StripConfig::guards_always
};
// Counts what the pipeline published and compares each OK depth with the renderer's truth of the pair it
// came from (the cycling source delivers frames[seq % frames.size()]).
class CountingSink final : public MeasurementSink {
 public:
  explicit CountingSink(std::vector<double> truth_depth_mm) : truth_(std::move(truth_depth_mm)) {}
  void publish(const PublishedFrame& f) override {
    ++published;
    if (f.measurement.status == RutStatus::Ok) {
      ++ok;
      depth_sum += f.measurement.depth_mm;
      const double err = std::abs(f.measurement.depth_mm - truth_[f.seq % truth_.size()]);
      worst_error_mm = std::max(worst_error_mm, err);
    }
  }
  void publish_status(const SensorHealth&, std::int64_t) override {}
  std::uint64_t published = 0, ok = 0;  // publish thread; read after stop()
  double depth_sum = 0, worst_error_mm = 0;

 private:
  std::vector<double> truth_;
};

double ms(std::int64_t ns) { return static_cast<double>(ns) * 1e-6; }

// `text` as the inside of a JSON string.
std::string json_escaped(const std::string& text) {
  std::string out;
  for (const char c : text) {
    if (c == '"' || c == '\\') out += '\\';
    if (static_cast<unsigned char>(c) >= 0x20) out += c;
  }
  return out;
}

// CPU time of the whole process (every thread: source, stages, OpenCV's workers), ms.
double process_cpu_ms() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  const auto tv_ms = [](const timeval& t) { return static_cast<double>(t.tv_sec) * 1e3 + t.tv_usec * 1e-3; };
  return tv_ms(u.ru_utime) + tv_ms(u.ru_stime);
}

void run(const char* mode, const char* regime, const SyntheticRenderer& renderer,
         const std::vector<StereoFrame>& frames, const MeasurerConfig& mc, bool lossless, double fps,
         const Options& o) {
  const StereoMeasurer measurer(renderer.calibration(), mc);
  MeasurerStages stages(measurer);
  const auto period =
      fps > 0 ? std::chrono::nanoseconds(static_cast<std::int64_t>(1e9 / fps)) : std::chrono::nanoseconds(0);
  CyclingSource source(renderer.calibration(), frames, period);
  std::vector<double> truth;
  for (std::size_t i = 0; i < frames.size(); ++i) truth.push_back(renderer.truth(i).depth_mm);
  CountingSink sink(std::move(truth));
  PipelineConfig config;
  config.lossless = lossless;
  config.max_frame_age = std::chrono::milliseconds(0);  // measure, do not refuse
  RealtimePipeline pipeline(source, stages, sink, config);
  const double cpu0 = process_cpu_ms();
  pipeline.start();
  std::this_thread::sleep_for(std::chrono::duration<double>(o.seconds));
  const PipelineStats s = pipeline.stats();
  const double cpu_ms = process_cpu_ms() - cpu0;
  pipeline.stop();
  const double hz = static_cast<double>(s.published) / o.seconds;
  // CPU per published pair: with the stages on separate threads, hardware_concurrency / cpu_per_pair is
  // the rate a machine of that many idle cores could reach, whatever else shares this one.
  const double cpu_per_pair = s.published > 0 ? cpu_ms / static_cast<double>(s.published) : 0.0;
  const StripRoi strip = measurer.strip();
  // Where the engine computed (its device and driver, or the CPU and why), at the end of the run.
  const std::string device = stages.engine().device();
  if (o.json) {
    // depth_err_mm: the worst |depth - truth| over the OK measurements (null when there was none).
    const std::string err = sink.ok ? fmt::format("{:.4f}", sink.worst_error_mm) : "null";
    std::printf(
        "{\"mode\":\"%s\",\"run\":\"%s\",\"engine\":\"%s\",\"dic\":%s,\"width\":%d,\"height\":%d,"
        "\"rows\":%d,\"hz\":%.2f,\"p50_ms\":%.3f,\"p99_ms\":%.3f,\"depth_err_mm\":%s,\"published\":%llu,"
        "\"ok\":%llu,\"dropped\":%llu,\"rectify_p50_ms\":%.3f,\"match_p50_ms\":%.3f,"
        "\"extract_p50_ms\":%.3f,\"cpu_ms_per_pair\":%.3f,\"device\":\"%s\"}\n",
        mode, regime, std::string(to_string(mc.engine)).c_str(), mc.dic ? "true" : "false",
        renderer.calibration().image_size.width, renderer.calibration().image_size.height, strip.rows, hz,
        ms(s.end_to_end.p50_ns), ms(s.end_to_end.p99_ns), err.c_str(), static_cast<unsigned long long>(s.published),
        static_cast<unsigned long long>(sink.ok), static_cast<unsigned long long>(s.dropped_total()),
        ms(s.stage_latency[1].p50_ns), ms(s.stage_latency[2].p50_ns), ms(s.stage_latency[3].p50_ns), cpu_per_pair,
        json_escaped(device).c_str());
    std::fflush(stdout);
    return;
  }
  // The device once, and again should a run end elsewhere (the GPU engine falling back to the CPU).
  static std::string last_device;
  if (device != last_device)
    std::printf("engine %s on %s\n", std::string(to_string(mc.engine)).c_str(), device.c_str());
  last_device = device;
  std::printf(
      "%-6s %-10s rows %3d..%3d  published %4llu (%3llu ok, depth %.2f mm, worst error %.3f mm)  %7.2f Hz  "
      "e2e p50 %8.2f p99 %8.2f ms | rectify %6.2f match %8.2f extract %6.2f ms (p50) | dropped %llu | cpu %.2f "
      "ms/pair\n",
      mode, regime, strip.row0, strip.row0 + strip.rows, static_cast<unsigned long long>(s.published),
      static_cast<unsigned long long>(sink.ok), sink.ok ? sink.depth_sum / static_cast<double>(sink.ok) : 0.0,
      sink.worst_error_mm, hz, ms(s.end_to_end.p50_ns), ms(s.end_to_end.p99_ns), ms(s.stage_latency[1].p50_ns),
      ms(s.stage_latency[2].p50_ns), ms(s.stage_latency[3].p50_ns), static_cast<unsigned long long>(s.dropped_total()),
      cpu_per_pair);
  std::fflush(stdout);
}

int run_bench(const Options& o) {
  SyntheticRendererConfig p;
  const auto size = parse_dimensions(o.size, 64, 8192);
  if (!size)
    throw CLI::ValidationError("--size", "expected WIDTHxHEIGHT between 64x64 and 8192x8192, got '" + o.size + "'");
  p.rig.image_size = *size;
  const SyntheticRenderer renderer(p);
  const std::vector<StereoFrame> frames = renderer.render_pairs(static_cast<std::size_t>(o.frames));
  // With --json, stdout carries only the JSON lines.
  std::fprintf(o.json ? stderr : stdout,
               "%dx%d synthetic pairs, truth depth %.2f mm, engine %s, DIC %s, %u hardware threads, %.0f s per run\n",
               p.rig.image_size.width, p.rig.image_size.height, renderer.truth(0).depth_mm, o.engine.c_str(),
               o.dic ? "on" : "off", std::thread::hardware_concurrency(), o.seconds);
  MeasurerConfig strip;
  strip.engine = *parse_engine(o.engine);
  strip.dic = o.dic;
  strip.strip.guards = o.guards;
  strip.strip.guards_always = o.guards_always;
  MeasurerConfig full = strip;
  full.strip = StripConfig{p.rig.image_size.height, 0};
  run("strip", "throughput", renderer, frames, strip, true, 0, o);
  run("strip", "live", renderer, frames, strip, false, o.fps, o);
  run("full", "throughput", renderer, frames, full, true, 0, o);
  run("full", "live", renderer, frames, full, false, o.fps, o);
  return 0;
}

}  // namespace

void add_bench_command(CLI::App& app, int& exit_code) {
  auto o = std::make_shared<Options>();
  CLI::App* cmd = app.add_subcommand(
      "bench",
      "Print the pipeline's rate and latency on synthetic pairs; --tables: the seed paper's Tables 1-3; --pair: every "
      "engine on a rectified pair with ground truth; --scenes: the scene matrix's outcomes against the truth");
  cmd->add_option("--seconds", o->seconds, "Length of each run")->check(CLI::Range(0.5, 600.0))->capture_default_str();
  cmd->add_option("--fps", o->fps, "Camera rate of the live runs")
      ->check(CLI::Range(1.0, 1000.0))
      ->capture_default_str();
  cmd->add_option("--frames", o->frames, "Distinct pairs rendered and cycled (--scenes: pairs per scene)")
      ->check(CLI::Range(1, 100))
      ->capture_default_str();
  cmd->add_option("--engine", o->engine, "Disparity engine")
      ->check(CLI::IsMember({"bm", "sgbm", "sgbm3way", "hh4", "hh", "gpu", "sgmref"}))
      ->capture_default_str();
  cmd->add_option("--size", o->size, "Image size WIDTHxHEIGHT")->capture_default_str();
  cmd->add_option("--guard-strips", o->guards,
                  "Guard strips measured on the frames the strip finds OK after water was seen, to look for it (0: "
                  "none)")
      ->check(CLI::Range(0, 2))
      ->capture_default_str();
  cmd->add_flag("--guards-always", o->guards_always, "Guard strips on every frame the strip finds OK");
  auto no_dic = std::make_shared<bool>(false);
  cmd->add_flag("--no-dic", *no_dic, "No sub-pixel refinement");
  cmd->add_flag("--json", o->json,
                "One JSON object per run on stdout (mode, run, engine, dic, width, height, rows, hz, "
                "p50_ms, p99_ms, depth_err_mm, ..., device) instead of the text table");
  // The seed paper's tables and the evaluation of a user's own pair (bench_tables.cpp, bench_pair.cpp).
  auto tables = std::make_shared<BenchTablesOptions>();
  auto pair = std::make_shared<BenchPairOptions>();
  auto table_list = std::make_shared<std::vector<int>>();
  auto pair_files = std::make_shared<std::vector<std::string>>();
  auto engines = std::make_shared<std::vector<std::string>>();
  cmd->add_option("--tables", *table_list, "Print the seed paper's tables instead: 1 rate, 2 surface error, 3 depth")
      ->delimiter(',')
      ->check(CLI::Range(1, 3));
  cmd->add_option("--sizes", tables->sizes, "Image sizes of the tables")->delimiter(',')->capture_default_str();
  cmd->add_option("--engines", *engines,
                  "Engines of --tables and --pair (default: the five OpenCV engines; gpu and sgmref on request)")
      ->delimiter(',')
      ->check(CLI::IsMember({"bm", "sgbm", "sgbm3way", "hh4", "hh", "gpu", "sgmref"}));
  auto* pair_opt =
      cmd->add_option("--pair", *pair_files, "Evaluate every engine on this rectified pair LEFT RIGHT (needs --gt)")
          ->expected(2);
  auto* gt_opt = cmd->add_option("--gt", pair->gt, "Ground-truth disparity image of --pair (0 = unknown)");
  cmd->add_option("--gt-scale", pair->gt_scale, "Ground-truth value / this = disparity in px")->capture_default_str();
  cmd->add_option("--dmin", pair->dmin, "Smallest disparity searched (default: from the ground truth)");
  cmd->add_option("--dmax", pair->dmax, "Largest disparity searched (default: from the ground truth)");
  pair_opt->needs(gt_opt);
  gt_opt->needs(pair_opt);
  // The scene matrix (bench_scenes.cpp): water, faults on the lenses, clean scenes, skewed pairs.
  auto scenes = std::make_shared<BenchScenesOptions>();
  auto run_scenes = std::make_shared<bool>(false);
  CLI::Option* scenes_flag = cmd->add_flag("--scenes", *run_scenes,
                                           "Measure the scene matrix instead (spoiled, clean and skewed synthetic "
                                           "scenes) and print the scene x outcome table against the truth");
  cmd->add_option("--only", scenes->only, "--scenes: only the scenes whose name matches this regular expression")
      ->needs(scenes_flag);
  cmd->callback([o, no_dic, tables, pair, table_list, pair_files, engines, scenes, run_scenes, &exit_code] {
    o->dic = !*no_dic;
    if (*run_scenes) {
      scenes->frames = o->frames;
      scenes->engine = o->engine;
      scenes->dic = o->dic;
      scenes->json = o->json;
      scenes->guards = o->guards;
      scenes->guards_always = o->guards_always;
      exit_code = run_bench_scenes(*scenes);
    } else if (!pair_files->empty()) {
      pair->left = (*pair_files)[0];
      pair->right = (*pair_files)[1];
      pair->json = o->json;
      if (!engines->empty()) pair->engines = *engines;
      exit_code = run_bench_pair(*pair);
    } else if (!table_list->empty()) {
      tables->tables = *table_list;
      tables->seconds = o->seconds;
      tables->json = o->json;
      if (!engines->empty()) tables->engines = *engines;
      exit_code = run_bench_tables(*tables);
    } else {
      exit_code = run_bench(*o);
    }
  });
}

}  // namespace rutd
