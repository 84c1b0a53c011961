#include "daemon/config.hpp"

#include <chrono>
#include <fstream>
#include <functional>
#include <optional>
#include <set>
#include <sstream>

#include <yaml-cpp/yaml.h>

#include "can/dbc_signal.hpp"
#include "core/csv_fields.hpp"
#include "core/input_error.hpp"
#include "daemon/dimensions.hpp"
#include "default_config.hpp"  // generated from config/rutd.yaml

namespace rutd {
namespace {

// One YAML mapping being read: remembers which keys were asked for so that a key nobody reads (a typo)
// is an error rather than silently ignored.
class Section {
 public:
  Section(YAML::Node node, std::string path, const std::string& file)
      : node_(std::move(node)), path_(std::move(path)), file_(file) {
    if (node_ && !node_.IsNull() && !node_.IsMap())
      fail_at(node_, path_.empty() ? "(top level)" : path_, "expected a mapping of keys");
  }

  // Reads `key` into `out` if present (absent keeps the default); `check` returns "" or what is wrong.
  template <typename T>
  Section& get(const char* key, T& out, const std::function<std::string(const T&)>& check = {}) {
    known_.insert(key);
    const YAML::Node value = present(key);
    if (!value) return *this;
    T parsed{};
    try {
      if (!value.IsScalar()) throw YAML::Exception(value.Mark(), "");
      parsed = value.as<T>();
    } catch (const YAML::Exception&) {
      fail_at(value, name(key), std::string("expected ") + type_name<T>() + ", got '" + text(value) + "'");
    }
    if (check) {
      const std::string problem = check(parsed);
      if (!problem.empty()) fail_at(value, name(key), problem);
    }
    out = parsed;
    return *this;
  }

  // Reads `key` as text and hands it to `parse`, which returns "" or what is wrong.
  Section& parse(const char* key, const std::function<std::string(const std::string&)>& parse_text) {
    std::string s;
    get<std::string>(key, s);
    if (const YAML::Node value = present(key)) {
      const std::string problem = parse_text(s);
      if (!problem.empty()) fail_at(value, name(key), problem);
    }
    return *this;
  }

  Section& get_int_list(const char* key, std::vector<int>& out) {
    known_.insert(key);
    const YAML::Node value = present(key);
    if (!value) return *this;
    if (!value.IsSequence()) fail_at(value, name(key), "expected a list of integers");
    out.clear();
    for (const auto& item : value) {
      try {
        out.push_back(item.as<int>());
      } catch (const YAML::Exception&) {
        fail_at(item, name(key), "expected an integer, got '" + text(item) + "'");
      }
    }
    return *this;
  }

  // A list of mappings, each read as a Section named KEY[i].
  std::vector<Section> children(const char* key) {
    known_.insert(key);
    std::vector<Section> out;
    const YAML::Node value = present(key);
    if (!value) return out;
    if (!value.IsSequence()) fail_at(value, name(key), "expected a list");
    for (std::size_t i = 0; i < value.size(); ++i)
      out.emplace_back(value[i], name(key) + "[" + std::to_string(i) + "]", file_);
    return out;
  }

  // A list of [number, number] pairs.
  Section& get_pairs(const char* key, std::vector<std::pair<double, double>>& out) {
    known_.insert(key);
    const YAML::Node value = present(key);
    if (!value) return *this;
    if (!value.IsSequence()) fail_at(value, name(key), "expected a list of [number, number] pairs");
    out.clear();
    for (const auto& item : value) {
      try {
        if (!item.IsSequence() || item.size() != 2) throw YAML::Exception(item.Mark(), "");
        out.emplace_back(item[0].as<double>(), item[1].as<double>());
      } catch (const YAML::Exception&) {
        fail_at(item, name(key), "expected a pair [number, number], got '" + text(item) + "'");
      }
    }
    return *this;
  }

  Section child(const char* key) {
    known_.insert(key);
    return Section(present(key), name(key), file_);
  }

  // A key of an older release that has moved: refused, naming the key that replaced it (a file written
  // for another release must not be half-read).
  Section& moved(const char* key, const std::string& now) {
    known_.insert(key);
    if (!node_ || !node_.IsMap()) return *this;
    for (const auto& kv : node_)
      if (key_text(kv.first) == key) fail_at(kv.first, name(key), "moved: now " + now);
    return *this;
  }

  bool has(const char* key) const { return static_cast<bool>(present(key)); }

  // Every key of the mapping must have been read.
  void finish() const {
    if (!node_ || !node_.IsMap()) return;
    for (const auto& kv : node_) {
      const std::string key = key_text(kv.first);
      if (!known_.count(key)) {
        std::string known;
        for (const auto& k : known_) known += (known.empty() ? "" : ", ") + k;
        fail_at(kv.first, name(key.c_str()), "unknown key (known here: " + known + ")");
      }
    }
  }

  [[noreturn]] void fail(const char* key, const std::string& message) const {
    const YAML::Node value = present(key);
    fail_at(value ? value : node_, name(key), message);
  }

 private:
  YAML::Node present(const char* key) const {
    if (!node_ || !node_.IsMap()) return YAML::Node(YAML::NodeType::Undefined);
    for (const auto& kv : node_)
      if (key_text(kv.first) == key) return kv.second;
    return YAML::Node(YAML::NodeType::Undefined);
  }
  // A key is a plain name. YAML also allows a list or a mapping as a key ("? [a, b]: 1"), which
  // as<std::string>() would throw on as a YAML::BadConversion that no caller expects (found by fuzzing).
  std::string key_text(const YAML::Node& key) const {
    if (!key.IsScalar())
      fail_at(key, path_.empty() ? "(top level)" : path_, "a key must be a plain name, got '" + text(key) + "'");
    return key.Scalar();
  }
  std::string name(const char* key) const { return path_.empty() ? key : path_ + "." + key; }
  static std::string text(const YAML::Node& n) {
    if (n.IsScalar()) return n.Scalar();
    std::ostringstream os;
    os << n;
    return os.str();
  }
  [[noreturn]] void fail_at(const YAML::Node& at, const std::string& key, const std::string& message) const {
    const int line = at && at.Mark().line >= 0 ? at.Mark().line + 1 : 0;
    throw InputError(file_, (line > 0 ? "line " + std::to_string(line) + ", " : std::string()) + key, message);
  }
  template <typename T>
  static const char* type_name() {
    if constexpr (std::is_same_v<T, bool>) return "true or false";
    else if constexpr (std::is_integral_v<T>) return "an integer";
    else if constexpr (std::is_floating_point_v<T>) return "a number";
    else return "text";
  }

  YAML::Node node_;
  std::string path_;
  const std::string& file_;
  std::set<std::string> known_;
};

template <typename T>
std::function<std::string(const T&)> in_range(T lo, T hi) {
  return [lo, hi](const T& v) {
    if (v >= lo && v <= hi) return std::string();
    std::ostringstream os;
    os << "must be between " << lo << " and " << hi << ", got " << v;
    return os.str();
  };
}

std::string parse_size(const std::string& s, cv::Size& size) {
  const auto parsed = parse_dimensions(s, 64, 8192);
  if (!parsed) return "expected WIDTHxHEIGHT between 64x64 and 8192x8192, got '" + s + "'";
  size = *parsed;
  return {};
}

// Accepts decimal or 0x-prefixed hexadecimal.
std::string parse_byte(const std::string& s, std::uint8_t& out, unsigned max) {
  std::size_t used = 0;
  unsigned long v = 0;
  try {
    v = std::stoul(s, &used, 0);
  } catch (const std::exception&) {
    used = 0;
  }
  if (used != s.size() || v > max)
    return "expected an integer 0.." + std::to_string(max) + " (decimal or 0x..), got '" + s + "'";
  out = static_cast<std::uint8_t>(v);
  return {};
}

void read_synthetic(Section s, SyntheticRendererConfig& p, int& cycle_frames) {
  s.parse("size", [&](const std::string& t) { return parse_size(t, p.rig.image_size); })
      .get<double>("fps", p.fps, in_range(0.1, 1000.0))
      .get<double>("baseline_mm", p.rig.baseline_mm, in_range(5.0, 1000.0))
      .get<double>("height_mm", p.rig.height_mm, in_range(50.0, 5000.0))
      .get<double>("roll_deg", p.rig.roll_deg, in_range(-30.0, 30.0))
      .get<double>("pitch_deg", p.rig.pitch_deg, in_range(-30.0, 30.0))
      .get<double>("hfov_deg", p.rig.hfov_deg, in_range(10.0, 120.0))
      .parse("texture",
             [&](const std::string& t) {
               const auto tex = parse_texture(t);
               if (!tex) return "expected sand, mud, snow or grass, got '" + t + "'";
               p.texture = *tex;
               return std::string();
             })
      .get<double>("depth_mm", p.rut.depth_mm, in_range(0.5, 500.0))
      .get<double>("width_mm", p.rut.width_mm, in_range(10.0, 2000.0))
      .get<double>("bottom_width_mm", p.rut.bottom_width_mm, in_range(0.0, 2000.0))
      .get<double>("pile_left_mm", p.rut.pile_left_mm, in_range(0.0, 300.0))
      .get<double>("pile_right_mm", p.rut.pile_right_mm, in_range(0.0, 300.0))
      .get<double>("pile_width_mm", p.rut.pile_width_mm, in_range(1.0, 1000.0))
      .get<double>("wander_mm", p.rut.wander_amplitude_mm, in_range(0.0, 1000.0))
      .get<double>("speed_mm_s", p.speed_mm_s, in_range(0.0, 1e5))
      .get<double>("noise", p.noise_sigma, in_range(0.0, 50.0))
      .get<std::uint64_t>("seed", p.seed)
      .get<int>("cycle_frames", cycle_frames, in_range(0, 1000));
  if (p.rut.bottom_width_mm >= p.rut.width_mm) s.fail("bottom_width_mm", "must be smaller than width_mm");
  s.finish();
}

// measurement.strip.first_row: a row number, or `centred`.
std::string parse_first_row(const std::string& t, std::optional<int>& row) {
  if (t == "centred") {
    row.reset();
    return {};
  }
  std::size_t used = 0;
  int v = -1;
  try {
    v = std::stoi(t, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (used == t.size() && v >= 0 && v <= 65535) {
    row = v;
    return {};
  }
  return "expected centred or a row number 0..65535, got '" + t + "'" +
         (t == "-1" ? std::string(" (-1 for centred is now written centred)") : std::string());
}

void read_strip(Section s, StripConfig& strip) {
  std::optional<int> first_row = strip.first_row;
  s.get<int>("rows", strip.rows, in_range(0, 4096))
      .parse("first_row", [&](const std::string& t) { return parse_first_row(t, first_row); })
      .get<int>("guards", strip.guards, in_range(0, 2))
      .get<double>("guard_spacing", strip.guard_spacing, in_range(0.05, 0.5))
      .get<bool>("guards_always", strip.guards_always)
      .get<double>("guard_after_water_s", strip.guard_after_water_s, in_range(0.0, 3600.0))
      .get<double>("frames_together_s", strip.frames_together_s, in_range(0.0, 2.0));
  if (first_row && strip.rows == 0) s.fail("first_row", "needs rows too");
  strip.first_row = first_row;
  s.finish();
}

void read_measurement(Section s, MeasurerConfig& m) {
  s.moved("strip_rows", "measurement.strip.rows").moved("strip_row0", "measurement.strip.first_row (centred or a row)");
  s.parse("engine",
          [&](const std::string& t) {
            const auto e = parse_engine(t);
            if (!e) return "expected bm, sgbm, sgbm3way, hh4, hh, gpu or sgmref, got '" + t + "'";
            m.engine = *e;
            return std::string();
          })
      .get<bool>("dic", m.dic)
      .get<bool>("low_texture_read", m.low_texture_read)
      .get<int>("gap_fill_half_window", m.gap_fill_half_window,
                [&](const int& v) { return gap_fill_window_problem(v, m.dic_config.half_window); })
      .get<std::string>("gpu_device", m.engine_config.gpu_device)
      .get<int>("sgm_paths", m.engine_config.sgm_paths,
                [](const int& v) {
                  return v == 2 || v == 4 || v == 8 ? std::string() : "expected 2, 4 or 8, got " + std::to_string(v);
                })
      .get<int>("sgm_segment", m.engine_config.sgm_segment,
                [](const int& v) {
                  return v == 0 || (v >= 16 && v <= 65535) ? std::string()
                                                           : "expected 0 (off) or 16..65535, got " + std::to_string(v);
                })
      .get<double>("near_mm", m.range.near_mm, in_range(20.0, 20000.0))
      .get<double>("far_mm", m.range.far_mm, in_range(20.0, 20000.0));
  if (m.range.near_mm >= m.range.far_mm) s.fail("near_mm", "must be smaller than far_mm");
  read_strip(s.child("strip"), m.strip);
  s.finish();
}

void read_rut(Section s, RutConfig& r) {
  s.get<double>("min_width_mm", r.min_rut_width_mm, in_range(10.0, 5000.0))
      .get<double>("max_width_mm", r.max_rut_width_mm, in_range(10.0, 5000.0))
      .get<double>("fit_window_mm", r.fit_window_mm, in_range(2.0, 500.0))
      .get<double>("bin_mm", r.bin_mm, in_range(0.1, 20.0))
      .get<double>("min_depth_mm", r.min_rut_depth_mm, in_range(0.1, 500.0))
      .get<double>("max_depth_uncertainty_mm", r.max_depth_uncertainty_mm, in_range(0.01, 40.0))
      .get<double>("vegetation_roughness_mm", r.vegetation_roughness_mm, in_range(0.05, 100.0));
  if (r.min_rut_width_mm >= r.max_rut_width_mm) s.fail("min_width_mm", "must be smaller than max_width_mm");
  s.finish();
}

void read_conditions(Section s, ConditionConfig& c) {
  s.get<bool>("enabled", c.enabled)
      .get<double>("obstruction_ratio", c.obstruction_ratio, in_range(0.01, 0.99))
      .get<double>("min_texture", c.min_texture, in_range(0.0, 255.0))
      .get<double>("obstruction_min_fraction", c.obstruction_min_fraction, in_range(0.001, 1.0))
      .get<double>("veil_brightening", c.veil_brightening, in_range(0.0, 10.0))
      .get<double>("low_light_level", c.low_light_level, in_range(0.0, 0.99))
      .get<double>("low_light_texture_to_noise", c.low_light_texture_to_noise, in_range(0.0, 100.0))
      .get<double>("low_light_noise", c.low_light_noise, in_range(0.001, 0.99))
      .get<double>("overexposed_fraction", c.overexposed_fraction, in_range(0.001, 1.0))
      .get<double>("flat_ratio", c.flat_ratio, in_range(0.01, 0.99))
      .get<double>("flat_min_width_mm", c.flat_min_width_mm, in_range(0.1, 1000.0))
      .get<double>("flat_min_unseen_mm", c.flat_min_unseen_mm, in_range(0.0, 1000.0))
      .get<double>("specular_coherence", c.specular_coherence, in_range(0.01, 1.0))
      .get<double>("specular_min_disagreement", c.specular_min_disagreement, in_range(0.0, 0.99))
      .get<double>("specular_brightening", c.specular_brightening, in_range(0.0, 10.0))
      .get<int>("specular_min_blocks", c.specular_min_blocks, in_range(1, 1000))
      .get<double>("max_vertical_disparity_px", c.max_vertical_disparity_px, in_range(0.01, 32.0))
      .get<double>("unsynchronised_skew_ms", c.unsynchronised_skew_ms, in_range(0.0, 1000.0))
      .get<double>("vegetation_unmatched_share", c.vegetation_unmatched_share, in_range(0.01, 1.0))
      .get<int>("vegetation_min_blocks", c.vegetation_min_blocks, in_range(1, 1000));
  s.finish();
}

void read_can(Section s, CanIdConfig& c) {
  s.parse("id_format",
          [&](const std::string& t) {
            if (t != "j1939" && t != "11bit") return "expected j1939 or 11bit, got '" + t + "'";
            c.extended = t == "j1939";
            return std::string();
          })
      .parse("source_address", [&](const std::string& t) { return parse_byte(t, c.source_address, 0xFD); })
      .parse("priority", [&](const std::string& t) { return parse_byte(t, c.priority, 7); });
  if (const std::string problem = check_can_id_config(c); !problem.empty()) s.fail("id_format", problem);
  s.finish();
}

// A sensor rectangle written [x, y, width, height]; [0, 0, 0, 0] is the whole sensor.
void read_region(Section& s, const char* key, SensorRegion& r) {
  std::vector<int> v{r.x, r.y, r.width, r.height};
  s.get_int_list(key, v);
  if (v.size() != 4) s.fail(key, "expected [x, y, width, height]");
  if (v[0] < 0 || v[1] < 0 || v[2] < 0 || v[3] < 0 || v[0] > 65535 || v[1] > 65535 || v[2] > 65535 || v[3] > 65535)
    s.fail(key, "values must be 0..65535");
  if ((v[2] == 0) != (v[3] == 0)) s.fail(key, "width and height are both 0 (whole sensor) or both set");
  r = SensorRegion{v[0], v[1], v[2], v[3]};
}

void read_aravis(Section s, AravisSourceConfig& a) {
  s.get<std::string>("left", a.left)
      .get<std::string>("right", a.right)
      .parse("pixel_format",
             [&](const std::string& t) {
               if (t == "mono8") a.pixel_format = CameraPixelFormat::Mono8;
               else if (t == "mono16") a.pixel_format = CameraPixelFormat::Mono16;
               else if (t == "bayer") a.pixel_format = CameraPixelFormat::Bayer8;
               else return "expected mono8, mono16 or bayer, got '" + t + "'";
               return std::string();
             })
      .get<int>("binning", a.binning, in_range(1, 8))
      .get<double>("fps", a.fps, in_range(0.1, 1000.0))
      .parse("sync",
             [&](const std::string& t) {
               if (t == "free_run") a.sync = CameraSync::FreeRun;
               else if (t == "software_trigger") a.sync = CameraSync::SoftwareTrigger;
               else if (t == "hardware_trigger") a.sync = CameraSync::HardwareTrigger;
               else return "expected free_run, software_trigger or hardware_trigger, got '" + t + "'";
               return std::string();
             })
      .get<std::string>("trigger_line", a.trigger_line)
      .get<bool>("exposure_auto", a.exposure_auto)
      .get<double>("exposure_us", a.exposure_us, in_range(1.0, 1e7))
      .get<double>("exposure_min_us", a.exposure_min_us, in_range(1.0, 1e7))
      .get<double>("exposure_max_us", a.exposure_max_us, in_range(1.0, 1e7))
      .get<bool>("gain_auto", a.gain_auto)
      .get<double>("gain_db", a.gain_db, in_range(0.0, 48.0))
      .get<double>("gain_max_db", a.gain_max_db, in_range(0.0, 48.0))
      .get<double>("pairing_window_ms", a.pairing_window_ms, in_range(0.001, 500.0))
      .get<double>("stall_timeout_ms", a.stall_timeout_ms, in_range(0.0, 60000.0))
      .get<double>("reconnect_min_ms", a.reconnect_min_ms, in_range(10.0, 60000.0))
      .get<double>("reconnect_max_ms", a.reconnect_max_ms, in_range(10.0, 600000.0))
      .get<int>("buffers", a.buffers, in_range(2, 64))
      .get<int>("packet_size", a.packet_size, in_range(0, 16384))
      .get<int>("packet_delay_ns", a.packet_delay_ns, in_range(0, 100000000))
      .get<int>("socket_buffer_bytes", a.socket_buffer_bytes, in_range(0, 1 << 30))
      .get<bool>("packet_resend", a.packet_resend)
      .get<bool>("packet_socket", a.packet_socket);
  read_region(s, "roi", a.roi);
  read_region(s, "metering_region", a.metering_region);
  if (a.exposure_min_us > a.exposure_max_us) s.fail("exposure_min_us", "must not be above exposure_max_us");
  if (a.reconnect_min_ms > a.reconnect_max_ms) s.fail("reconnect_min_ms", "must not be above reconnect_max_ms");
  if (a.pairing_window_ms * 2 >= 1000.0 / a.fps)
    s.fail("pairing_window_ms", "must be below half the frame period (1000 / fps / 2 ms), so a frame has one partner");
  if (a.stall_timeout_ms > 0 && a.stall_timeout_ms < 1000.0 / a.fps)
    s.fail("stall_timeout_ms", "must be at least one frame period (1000 / fps ms), or 0 for no stall detection");
  if (a.packet_size != 0 && a.packet_size < 576) s.fail("packet_size", "0 (negotiate) or at least 576 bytes");
  s.finish();
}

void read_plots(Section plots, SinkConfig& c) {
  int plot_every = 0, plot_queue = static_cast<int>(c.plots.queue);
  plots.get<bool>("enabled", c.plots_enabled)
      .get<std::string>("dir", c.plots.dir)
      .get<int>("every", plot_every, in_range(0, 1000000))
      .get<double>("min_interval_s", c.plots.min_interval_s, in_range(0.0, 3600.0))
      .get<int>("queue", plot_queue, in_range(1, 64))
      .get<double>("series_period_s", c.plots.series_period_s, in_range(0.0, 86400.0));
  if (c.plots_enabled && c.plots.dir.empty()) plots.fail("dir", "must name a folder when enabled is true");
  plots.finish();
  c.plots.every = static_cast<std::uint64_t>(plot_every);
  c.plots.queue = static_cast<std::size_t>(plot_queue);
}

// The `trafficability` section (TrafficabilityConfig).
void read_speed(Section s, TrafficabilityConfig& t) {
  VehicleSpeedConfig& v = t.speed;
  double max_age_ms = static_cast<double>(t.odometer.max_age_ns) / 1e6;
  double max_speed_kmh = v.max_speed_mm_s * 3.6 / 1000, max_accel = v.max_accel_mm_s2 / 1000;
  double min_interval_ms = static_cast<double>(v.min_interval_ns) / 1e6;
  std::string message = "ccvs1";
  s.get<std::string>("socketcan", t.socketcan)
      .parse("message",
             [&](const std::string& m) {
               if (m != "ccvs1" && m != "dbc") return "expected ccvs1 or dbc, got '" + m + "'";
               message = m;
               return std::string();
             })
      .get<std::string>("dbc", t.dbc)
      .get<std::string>("dbc_message", t.dbc_message)
      .get<std::string>("dbc_signal", t.dbc_signal)
      .parse("source_address",
             [&](const std::string& a) {
               if (a == "any") {
                 v.source_address = -1;
                 return std::string();
               }
               std::uint8_t b = 0;
               const std::string problem = parse_byte(a, b, 0xFD);
               v.source_address = b;
               return problem.empty() ? problem : problem + " or any";
             })
      .get<bool>("direction_from_gear", v.direction_from_gear)
      .get<double>("max_age_ms", max_age_ms, in_range(10.0, 10000.0))
      .get<double>("max_speed_kmh", max_speed_kmh, in_range(1.0, 500.0))
      .get<double>("max_accel_m_s2", max_accel, in_range(0.1, 200.0))
      .get<double>("min_interval_ms", min_interval_ms, in_range(0.0, 1000.0));
  t.odometer.max_age_ns = static_cast<std::int64_t>(max_age_ms * 1e6);
  v.max_speed_mm_s = max_speed_kmh / 3.6 * 1000;
  v.max_accel_mm_s2 = max_accel * 1000;
  v.min_interval_ns = static_cast<std::int64_t>(min_interval_ms * 1e6);
  if (message == "dbc") {
    if (t.dbc.empty() || t.dbc_message.empty() || t.dbc_signal.empty())
      s.fail("message", "message: dbc needs dbc, dbc_message and dbc_signal");
    try {
      v.signal = load_dbc_speed_signal(t.dbc, t.dbc_message, t.dbc_signal);
    } catch (const std::invalid_argument& e) {
      s.fail("dbc", e.what());
    }
  } else if (!t.dbc.empty()) {
    s.fail("dbc", "set message: dbc to read the speed from a DBC signal");
  }
  if (const std::string problem = check_vehicle_speed_config(v, "trafficability.speed"); !problem.empty())
    s.fail("message", problem);
  s.finish();
}

void read_trafficability(Section s, TrafficabilityConfig& t) {
  read_speed(s.child("speed"), t);
  SegmentConfig& g = t.segments;
  s.get<double>("segment_length_m", g.length_m, in_range(0.05, 1000.0))
      .get<std::string>("segments_csv", t.segments_csv);
  Section a = s.child("advisory");
  int min_frames = static_cast<int>(g.advisory.min_trusted_frames);
  a.get<double>("caution_depth_mm", g.advisory.caution_depth_mm, in_range(0.1, 2000.0))
      .get<double>("no_go_depth_mm", g.advisory.no_go_depth_mm, in_range(0.1, 2000.0))
      .get<double>("hysteresis_m", g.advisory.hysteresis_m, in_range(0.0, 1000.0))
      .get<double>("max_untrusted_fraction", g.advisory.max_untrusted_fraction, in_range(0.0, 1.0))
      .get<int>("min_trusted_frames", min_frames, in_range(1, 100000))
      .get<double>("coverage_factor", g.advisory.coverage_factor, in_range(0.0, 10.0));
  g.advisory.min_trusted_frames = static_cast<std::uint32_t>(min_frames);
  if (g.advisory.no_go_depth_mm < g.advisory.caution_depth_mm)
    a.fail("no_go_depth_mm", "must not be below caution_depth_mm");
  a.finish();
  Section soil = s.child("soil");
  std::vector<std::pair<double, double>> table;
  soil.get<std::string>("quantity", g.soil.quantity)
      .get<std::string>("units", g.soil.units)
      .get<std::string>("source", g.soil.source)
      .get_pairs("table", table)
      .get<double>("vehicle_limit_one_pass", g.soil.limit_one_pass, in_range(0.0, 1e6))
      .get<double>("vehicle_limit_fifty_passes", g.soil.limit_fifty_passes, in_range(0.0, 1e6));
  g.soil.table.clear();
  for (const auto& [mm, strength] : table) g.soil.table.push_back({mm, strength});
  if (const std::string problem = check_soil_strength_config(g.soil, "trafficability.soil"); !problem.empty())
    soil.fail("table", problem);
  soil.finish();
  if (s.has("damage")) g.damage.clear();
  for (Section r : s.children("damage")) {
    RutDamageRule rule;
    r.get<std::string>("name", rule.name)
        .get<double>("depth_mm", rule.depth_mm, in_range(0.1, 2000.0))
        .get<double>("min_length_m", rule.min_length_m, in_range(0.0, 1000.0))
        .get<double>("max_share", rule.max_share, in_range(0.001, 1.0));
    if (rule.name.empty()) r.fail("name", "name the rule (e.g. its guideline)");
    r.finish();
    g.damage.push_back(rule);
  }
  if (const std::string problem = check_segment_config(g, "trafficability"); !problem.empty())
    s.fail("segment_length_m", problem);
  s.finish();
}

// The `gps` section (gps/gps_config.hpp).
void read_gps(Section s, GpsConfig& g) {
  s.get<bool>("enabled", g.enabled)
      .get<std::string>("host", g.host,
                        [](const std::string& h) { return h.empty() ? std::string("must name gpsd's host") : ""; })
      .get<std::string>("port", g.port,
                        [](const std::string& p) {
                          int v = 0;
                          return parse_csv_number(p, v) && v >= 1 && v <= 65535
                                     ? std::string()
                                     : "expected a port number 1..65535, got '" + p + "'";
                        })
      .get<double>("max_fix_age_ms", g.max_fix_age_ms, in_range(10.0, 600000.0))
      .get<double>("reconnect_min_ms", g.reconnect_min_ms, in_range(10.0, 60000.0))
      .get<double>("reconnect_max_ms", g.reconnect_max_ms, in_range(10.0, 600000.0))
      .get<double>("time_jump_s", g.time_jump_s, in_range(0.01, 86400.0));
  if (g.reconnect_min_ms > g.reconnect_max_ms) s.fail("reconnect_min_ms", "must not be above reconnect_max_ms");
  s.finish();
}

// The `uplink` section (UplinkConfig); check_uplink_config's verdict names the key.
void read_uplink(Section s, UplinkConfig& u) {
  double max_mb = static_cast<double>(u.queue.max_bytes) / (1 << 20);
  double max_messages = static_cast<double>(u.queue.max_messages);
  std::string sync = u.queue.sync == OutboxSync::Full ? "full" : "normal";
  s.get<bool>("enabled", u.enabled)
      .get<std::string>("host", u.host)
      .get<int>("port", u.port)
      .get<std::string>("vehicle", u.vehicle)
      .get<std::string>("topic_prefix", u.topic_prefix)
      .get<int>("keepalive_s", u.keepalive_s)
      .get<std::string>("ca_file", u.ca_file)
      .get<std::string>("cert_file", u.cert_file)
      .get<std::string>("key_file", u.key_file)
      .get<std::string>("credentials_file", u.credentials_file)
      .get<int>("health_period_s", u.health_period_s)
      .get<int>("retry_min_ms", u.retry_min_ms)
      .get<int>("retry_max_ms", u.retry_max_ms)
      .get<int>("inflight", u.inflight);
  Section q = s.child("queue");
  q.get<std::string>("path", u.queue.path)
      .get<double>("max_mb", max_mb, in_range(0.01, 1e6))
      .get<double>("max_messages", max_messages, in_range(1.0, 1e9))
      .parse("sync", [&](const std::string& v) {
        if (v != "full" && v != "normal") return "expected full or normal, got '" + v + "'";
        sync = v;
        return std::string();
      });
  q.finish();
  u.queue.max_bytes = static_cast<std::uint64_t>(max_mb * (1 << 20));
  u.queue.max_messages = static_cast<std::uint64_t>(max_messages);
  u.queue.sync = sync == "full" ? OutboxSync::Full : OutboxSync::Normal;
  if (const std::string problem = check_uplink_config(u); !problem.empty()) {
    const std::string key = problem.substr(0, problem.find(':'));
    const std::string first = key.substr(0, key.find('.'));
    if (key.find('.') != std::string::npos)
      q.fail(key.substr(key.find('.') + 1).c_str(), problem.substr(key.size() + 2));
    s.fail(first.c_str(), problem.substr(key.size() + 2));
  }
  s.finish();
}

// The `web` section (web/web_config.hpp); check_web_config's verdict names the key.
void read_web(Section s, WebConfig& w) {
  s.get<bool>("enabled", w.enabled)
      .get<std::string>("bind", w.bind)
      .get<int>("port", w.port)
      .get<std::string>("token_file", w.token_file)
      .get<double>("rate_hz", w.rate_hz)
      .get<int>("threads", w.threads);
  if (const std::string problem = check_web_config(w); !problem.empty()) {
    const std::string key = problem.substr(0, problem.find(':'));
    s.fail(key.c_str(), problem.substr(key.size() + 2));
  }
  s.finish();
}

}  // namespace

RutdConfig parse_config(const std::string& yaml_text, const std::string& file) {
  RutdConfig c;
  c.file = file;
  YAML::Node root;
  try {
    root = YAML::Load(yaml_text);
  } catch (const YAML::Exception& e) {
    throw InputError(file, "line " + std::to_string(e.mark.line + 1), "not valid YAML: " + e.msg);
  }
  Section top(root, "", c.file);

  Section source = top.child("source");
  source.parse("type", [&](const std::string& t) {
    if (t == "synthetic") c.source = SourceKind::Synthetic;
    else if (t == "replay") c.source = SourceKind::Replay;
    else if (t == "aravis") c.source = SourceKind::Aravis;
    else return "expected synthetic, replay or aravis, got '" + t + "'";
    return std::string();
  });
  read_synthetic(source.child("synthetic"), c.synthetic, c.synthetic_cycle_frames);
  Section replay = source.child("replay");
  replay.get<std::string>("dir", c.replay.dir).get<bool>("paced", c.replay.paced).get<bool>("loop", c.replay.loop);
  replay.finish();
  if (c.source == SourceKind::Replay && c.replay.dir.empty())
    replay.fail("dir", "the replay source needs a recording folder");
  read_aravis(source.child("aravis"), c.aravis);
  source.get<std::string>("record", c.record).get<int>("record_buffer", c.record_buffer, in_range(1, 1024));
  source.finish();

  top.get<std::string>("calibration", c.calibration);
  if (c.source == SourceKind::Aravis && c.calibration.empty())
    top.fail("calibration", "cameras need a calibration file");
  if (c.source == SourceKind::Aravis) {
    Section aravis = source.child("aravis");
    if (c.aravis.left.empty()) aravis.fail("left", "the aravis source needs the left camera (id, serial or address)");
    if (c.aravis.right.empty())
      aravis.fail("right", "the aravis source needs the right camera (id, serial or address)");
    if (c.aravis.left == c.aravis.right) aravis.fail("right", "the same camera as left");
  }
  read_measurement(top.child("measurement"), c.measurement);
  read_rut(top.child("rut"), c.measurement.rut);
  read_conditions(top.child("conditions"), c.measurement.conditions);
  read_can(top.child("can"), c.can);

  Section sinks = top.child("sinks");
  sinks.moved("record", "source.record (a recording passes the source through; it is not a sink)")
      .get<std::string>("socketcan", c.sinks.socketcan)
      .get<std::string>("candump", c.sinks.candump)
      .get<std::string>("can_interface_name", c.sinks.can_interface_name)
      .get<std::string>("csv", c.sinks.csv)
      .get<bool>("csv_positions", c.sinks.csv_positions);
  read_plots(sinks.child("plots"), c.sinks);

  read_gps(top.child("gps"), c.gps);
  read_uplink(top.child("uplink"), c.uplink);
  read_web(top.child("web"), c.web);
  if (c.sinks.csv_positions && !c.gps.enabled) sinks.fail("csv_positions", "needs positions: gps.enabled: true");
  sinks.finish();

  Section pipeline = top.child("pipeline");
  double max_frame_age_ms = static_cast<double>(c.pipeline.max_frame_age.count());
  double status_period_ms = static_cast<double>(c.pipeline.status_period.count());
  std::vector<int> cpu_affinity;
  int realtime_priority = 0;
  pipeline.get<double>("max_frame_age_ms", max_frame_age_ms, in_range(1.0, 60000.0))
      .get<double>("status_period_ms", status_period_ms, in_range(10.0, 10000.0))
      .get_int_list("cpu_affinity", cpu_affinity)
      .get<int>("realtime_priority", realtime_priority, in_range(0, 99));
  pipeline.finish();
  c.pipeline.max_frame_age = std::chrono::milliseconds(static_cast<long>(max_frame_age_ms));
  c.pipeline.status_period = std::chrono::milliseconds(static_cast<long>(status_period_ms));
  for (std::size_t i = 0; i < cpu_affinity.size() && i < kStageCount; ++i) c.pipeline.threads[i].cpu = cpu_affinity[i];
  for (ThreadPlacement& t : c.pipeline.threads) t.fifo_priority = realtime_priority;

  top.moved("plots", "sinks.plots");
  read_trafficability(top.child("trafficability"), c.trafficability);

  Section logging = top.child("logging");
  logging.parse("level", [&](const std::string& t) {
    static const std::set<std::string> levels{"trace", "debug", "info", "warn", "error"};
    if (!levels.count(t)) return "expected trace, debug, info, warn or error, got '" + t + "'";
    c.logging.level = t;
    return std::string();
  });
  logging.get<double>("stats_period_s", c.logging.stats_period_s, in_range(0.1, 3600.0));
  logging.finish();
  top.finish();
  return c;
}

RutdConfig load_config(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw InputError(path, "file", "cannot open the configuration file");
  std::ostringstream text;
  text << in.rdbuf();
  return parse_config(text.str(), path);
}

const std::string& default_config_text() {
  static const std::string text = kDefaultConfigText;
  return text;
}

}  // namespace rutd
