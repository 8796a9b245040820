#include "daemon/bench_file.h"

#include <grp.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <sstream>
#include <vector>

#include "calib/bench_truth.h"
#include "calib/truth_comparison.h"
#include "io/truth_file.h"
#include "lab/lab_connection.h"
#include "nav/rotation.h"

namespace imubench::daemon {
namespace {

namespace fs = std::filesystem;
using io::checkKeys;
using io::Diagnostics;
using io::Dimension;
using io::quantityField;
using io::strField;
using io::subTable;

std::string resolve(const std::string& base_dir, const std::string& path) {
  if (path.empty() || fs::path(path).is_absolute() || base_dir.empty()) return path;
  return (fs::path(base_dir) / path).lexically_normal().string();
}

// A referenced device file's own diagnostics, reported at the key that names it.
void reportDeviceFile(const toml::table& t, std::string_view key, const Diagnostics& device_diag,
                      Diagnostics& diag) {
  const toml::node* n = t.get(key);
  diag.error(n != nullptr ? n->source() : t.source(),
             "device file \"" + device_diag.file() + "\" refused:\n" + device_diag.str());
}

void parseBenchTable(const toml::table& root, const std::string& base_dir, BenchConfig& b,
                     Diagnostics& diag) {
  const toml::table* t = subTable(root, "bench", diag, true);
  if (t == nullptr) return;
  checkKeys(*t, {"name", "storage", "control_socket", "plan_dir"}, "[bench]", diag);
  b.name = strField(*t, "name", diag, true).value_or("");
  if (t->get("name") != nullptr && b.name.empty()) diag.error(t->source(), "name is empty");
  b.storage_path = resolve(base_dir, strField(*t, "storage", diag, true).value_or(""));
  b.control_socket = resolve(base_dir, strField(*t, "control_socket", diag, true).value_or(""));
  b.plan_dir = resolve(base_dir, strField(*t, "plan_dir", diag, false).value_or(""));
}

void parseSite(const toml::table& root, BenchConfig& b, Diagnostics& diag) {
  const toml::table* t = subTable(root, "site", diag, true);
  if (t == nullptr) return;
  checkKeys(*t, {"latitude", "height", "gravity_mps2", "outer_axis_heading"}, "[site]", diag);
  if (auto lat = quantityField(*t, "latitude", Dimension::kAngle, diag)) {
    if (std::abs(*lat) > 0.5 * kPi) {
      diag.error(t->get("latitude")->source(), "latitude must be within [-90, 90] deg");
    }
    b.site.latitude_rad = *lat;
  }
  if (auto h = quantityField(*t, "height", Dimension::kLength, diag)) b.site.height_m = *h;
  if (const toml::node* g = t->get("gravity_mps2")) {
    const auto v = g->value<double>();
    if (!v || !(*v > 9.7 && *v < 9.9)) {
      diag.error(g->source(), "gravity_mps2 must be a number in (9.7, 9.9) m/s^2");
    } else {
      b.site.gravity_mps2 = *v;
    }
  }
  if (auto hd = quantityField(*t, "outer_axis_heading", Dimension::kAngle, diag, false)) {
    b.outer_axis_heading_rad = *hd;
  }
}

// Endpoint overrides (host/port for TCP, path for serial lines) shared by table and chamber.
void applyEndpoint(const toml::table& t, drivers::TransportSpec& tr, Diagnostics& diag) {
  if (auto host = strField(t, "host", diag, false)) tr.host = *host;
  if (auto port = io::intField(t, "port", diag, false, 1, 65535)) tr.port = static_cast<int>(*port);
  if (auto path = strField(t, "path", diag, false)) tr.device = *path;
}

std::string fmt(double v) {
  std::ostringstream ss;
  ss << v;
  return ss.str();
}

// A bench limit may only tighten the device's: a looser one is an error, not silently capped.
void tightenLimit(const toml::table& t, std::string_view key, Dimension dim,
                  std::string_view deg_unit, double& device_limit, Diagnostics& diag) {
  const auto v = quantityField(t, key, dim, diag, false);
  if (!v) return;
  if (!(*v > 0.0)) {
    diag.error(t.get(key)->source(), std::string(key) + " must be positive");
  } else if (device_limit > 0.0 && *v > device_limit) {
    diag.error(t.get(key)->source(),
               std::string(key) + " " + fmt(*v * kRadToDeg) + " " + std::string(deg_unit) +
                   " is looser than the device file's " + fmt(device_limit * kRadToDeg) + " " +
                   std::string(deg_unit) + ": a bench may only tighten the controller's limits");
  } else {
    device_limit = *v;
  }
}

const char* tableKindText(calib::TableKind kind) {
  return kind == calib::TableKind::kTwoAxis ? "two-axis" : "three-axis";
}

// [table] errors: a coefficient file's "table" section, of the device's table kind.
void parseTableErrors(const toml::table& t, const std::string& base_dir, BenchConfig& b,
                      Diagnostics& diag) {
  const auto file = strField(t, "errors", diag, false);
  if (!file) return;
  const std::string path = resolve(base_dir, *file);
  const io::TruthFileResult r = io::readTruthFile(path);
  if (!r.status.ok) {
    diag.error(t.get("errors")->source(), "errors: " + r.status.message);
  } else if (r.value.table_kind != b.table.kind) {
    diag.error(t.get("errors")->source(),
               "errors: " + path + " holds " + tableKindText(r.value.table_kind) +
                   " table errors, the table device is " + tableKindText(b.table.kind));
  } else {
    b.table_errors = r.value.table;
    b.table_errors_file = path;
  }
}

void parseTable(const toml::table& root, const std::string& base_dir, BenchConfig& b,
                Diagnostics& diag) {
  const toml::table* t = subTable(root, "table", diag, true);
  if (t == nullptr) return;
  checkKeys(*t,
            {"device", "host", "port", "path", "max_rate", "max_accel", "reading_gap", "errors"},
            "[table]", diag);
  if (auto v = quantityField(*t, "reading_gap", Dimension::kTime, diag, false)) {
    if (*v > 0.0 && *v <= 60.0) {
      b.table_reading_gap_s = *v;
    } else {
      diag.error(t->get("reading_gap")->source(), "reading_gap must be in (0, 60] s");
    }
  }
  const auto device = strField(*t, "device", diag, true);
  if (!device) return;
  Diagnostics ddiag(resolve(base_dir, *device));
  auto spec = drivers::loadTableDevice(ddiag.file(), ddiag);
  if (!spec) return reportDeviceFile(*t, "device", ddiag, diag);
  b.table = std::move(*spec);
  applyEndpoint(*t, b.table.transport, diag);
  tightenLimit(*t, "max_rate", Dimension::kRate, "deg/s", b.table.limits.max_rate, diag);
  tightenLimit(*t, "max_accel", Dimension::kAngularAccel, "deg/s^2", b.table.limits.max_accel,
               diag);
  parseTableErrors(*t, base_dir, b, diag);
}

void parseChamber(const toml::table& root, const std::string& base_dir, BenchConfig& b,
                  Diagnostics& diag) {
  const toml::table* t = subTable(root, "chamber", diag, false);
  if (t == nullptr) return;
  checkKeys(*t,
            {"device", "host", "port", "path", "safe_setpoint", "over_temperature", "poll_period",
             "imu_time_constant"},
            "[chamber]", diag);
  const auto device = strField(*t, "device", diag, true);
  if (!device) return;
  Diagnostics ddiag(resolve(base_dir, *device));
  auto spec = drivers::loadChamberDevice(ddiag.file(), ddiag);
  if (!spec) return reportDeviceFile(*t, "device", ddiag, diag);
  BenchChamber c;
  c.device = std::move(*spec);
  applyEndpoint(*t, c.device.transport, diag);
  if (auto v = quantityField(*t, "safe_setpoint", Dimension::kTemperature, diag, false)) {
    c.safe_setpoint_c = *v;
  }
  if (auto v = quantityField(*t, "over_temperature", Dimension::kTemperature, diag, false)) {
    c.over_temperature_c = *v;
  }
  if (auto v = quantityField(*t, "poll_period", Dimension::kTime, diag, false)) {
    if (*v >= 0.01 && *v <= 60.0) {
      c.poll_period_s = *v;
    } else {
      diag.error(t->get("poll_period")->source(), "poll_period must be in [0.01, 60] s");
    }
  }
  if (auto v = quantityField(*t, "imu_time_constant", Dimension::kTime, diag, false)) {
    if (*v >= 0.0 && *v <= 86400.0) {
      c.imu_time_constant_s = *v;
    } else {
      diag.error(t->get("imu_time_constant")->source(), "imu_time_constant must be in [0, 1 d]");
    }
  }
  if (c.safe_setpoint_c < c.device.temp_min_c || c.safe_setpoint_c > c.device.temp_max_c) {
    diag.error(t->source(), "safe_setpoint is outside the chamber's range");
  }
  if (c.over_temperature_c <= c.safe_setpoint_c) {
    diag.error(t->source(), "over_temperature must be above safe_setpoint");
  }
  b.chamber = std::move(c);
}

void parseImu(const toml::table& root, const std::string& base_dir, BenchConfig& b,
              Diagnostics& diag) {
  const toml::table* t = subTable(root, "imu", diag, true);
  if (t == nullptr) return;
  checkKeys(*t, {"layout", "interface", "serial", "max_clock_ratio"}, "[imu]", diag);
  b.imu.interface = strField(*t, "interface", diag, true).value_or("");
  b.imu.serial = strField(*t, "serial", diag, false).value_or("");
  if (auto ratio = io::intField(*t, "max_clock_ratio", diag, false, 1, kMaxClockRatio))
    b.imu.max_clock_ratio = static_cast<double>(*ratio);
  const auto layout = strField(*t, "layout", diag, true);
  if (!layout) return;
  b.imu.layout_file = resolve(base_dir, *layout);
  Diagnostics ddiag(b.imu.layout_file);
  auto parsed = drivers::loadImuLayoutFile(b.imu.layout_file, ddiag);
  if (!parsed) return reportDeviceFile(*t, "layout", ddiag, diag);
  b.imu.layout = std::move(*parsed);
}

void parseSafety(const toml::table& root, BenchConfig& b, Diagnostics& diag) {
  const toml::table* t = subTable(root, "safety", diag, false);
  if (t == nullptr) return;
  checkKeys(*t, {"comm_timeout", "imu_timeout"}, "[safety]", diag);
  for (auto [key, out] :
       {std::pair<std::string_view, double*>{"comm_timeout", &b.safety.comm_timeout_s},
        {"imu_timeout", &b.safety.imu_timeout_s}}) {
    if (auto v = quantityField(*t, key, Dimension::kTime, diag, false)) {
      if (*v > 0.0 && *v <= 60.0) {
        *out = *v;
      } else {
        diag.error(t->get(key)->source(), std::string(key) + " must be in (0, 60] s");
      }
    }
  }
}

// getgrnam_r's buffer when sysconf has no hint.
constexpr long kDefaultGrBuffer = 64L * 1024L;

// A group named by key, resolved now (the group database as the daemon starts).
std::optional<NamedGroup> groupField(const toml::table& t, std::string_view key,
                                     Diagnostics& diag) {
  const auto name = strField(t, key, diag, false);
  if (!name) return std::nullopt;
  const long hint = ::sysconf(_SC_GETGR_R_SIZE_MAX);
  std::vector<char> buf(static_cast<std::size_t>(hint > 0 ? hint : kDefaultGrBuffer));
  group gr{};
  group* found = nullptr;
  if (name->empty() || ::getgrnam_r(name->c_str(), &gr, buf.data(), buf.size(), &found) != 0 ||
      found == nullptr) {
    diag.error(t.get(key)->source(),
               std::string(key) + ": no group \"" + *name + "\" on this system");
    return std::nullopt;
  }
  return NamedGroup{*name, gr.gr_gid};
}

// The control socket's connection policy (daemon/control_server.h) and rights
// (daemon/control_rights.h).
void parseControl(const toml::table& root, const std::string& base_dir, BenchConfig& b,
                  Diagnostics& diag) {
  const toml::table* t = subTable(root, "control", diag, false);
  if (t == nullptr) return;
  checkKeys(
      *t, {"idle_timeout", "command_group", "read_group", "max_connections_per_uid", "stop_socket"},
      "[control]", diag);
  if (auto n = io::intField(*t, "max_connections_per_uid", diag, false, 0, kMaxConnectionsPerUid))
    b.control.max_connections_per_uid = static_cast<std::size_t>(*n);
  if (auto stop = strField(*t, "stop_socket", diag, false)) {
    b.control.stop_socket = resolve(base_dir, *stop);
    if (stop->empty() || b.control.stop_socket == b.control_socket) {
      diag.error(t->get("stop_socket")->source(),
                 "stop_socket must be a path other than [bench] control_socket");
    }
  }
  b.control.command_group = groupField(*t, "command_group", diag);
  b.control.read_group = groupField(*t, "read_group", diag);
  if (b.control.read_group && !b.control.command_group && t->get("command_group") == nullptr) {
    diag.error(t->get("read_group")->source(),
               "read_group needs command_group (who may command the bench)");
  }
  if (auto v = quantityField(*t, "idle_timeout", Dimension::kTime, diag, false)) {
    if (*v >= 0.0 && *v <= kMaxIdleTimeoutS) {
      b.control.idle_timeout_s = *v;
    } else {
      diag.error(t->get("idle_timeout")->source(),
                 "idle_timeout must be in [0, " + fmt(kMaxIdleTimeoutS) + "] s (0: none)");
    }
  }
}

// [acceptance]: "<parameter or group>" = "<number> <display unit>". The key must name
// calibration parameters (interchange.md flat names), the unit must be theirs.
void parseAcceptance(const toml::table& root, BenchConfig& b, Diagnostics& diag) {
  const toml::table* t = subTable(root, "acceptance", diag, false);
  if (t == nullptr) return;
  const std::vector<std::string> names = calib::flatNames(calib::BenchTruth{});
  for (const auto& [key, node] : *t) {
    const std::string k(key.str());
    const auto first = std::find_if(names.begin(), names.end(), [&k](const std::string& n) {
      return n == k || n.rfind(k + ".", 0) == 0;
    });
    if (first == names.end() || k.rfind("extra.", 0) == 0) {
      diag.error(node.source(), "[acceptance] \"" + k +
                                    "\": not a calibration parameter or group (e.g. "
                                    "\"gyro.bias\", \"accel.scale.x\")");
      continue;
    }
    const calib::DisplayUnit unit = calib::displayUnit(*first);
    const auto* s = node.as_string();
    const std::string text = s != nullptr ? s->get() : std::string();
    char* end = nullptr;
    const double v = std::strtod(text.c_str(), &end);
    std::string rest = end != nullptr ? std::string(end) : std::string();
    rest.erase(0, rest.find_first_not_of(' '));
    if (s == nullptr || end == text.c_str() || rest != unit.label || !(v >= 0.0) ||
        !std::isfinite(v)) {
      diag.error(node.source(), "[acceptance] \"" + k + "\" must be a string \"<limit> " +
                                    unit.label + "\" with a limit >= 0, e.g. \"10 " + unit.label +
                                    "\"");
      continue;
    }
    b.acceptance.push_back({k, v * unit.si_per_unit, text});
  }
}

// [lab]: the mirror's database. A password in the connection string is refused at its key:
// credentials never live in the bench file (a file only the daemon's user reads, or libpq's).
void parseLab(const toml::table& root, const std::string& base_dir, BenchConfig& b,
              Diagnostics& diag) {
  const toml::table* t = subTable(root, "lab", diag, false);
  if (t == nullptr) return;
  checkKeys(*t, {"database", "password_file", "mirror_samples"}, "[lab]", diag);
  BenchLab lab;
  lab.database = strField(*t, "database", diag, true).value_or("");
  if (t->get("database") != nullptr) {
    if (lab.database.empty()) {
      diag.error(t->get("database")->source(), "database is empty");
    } else if (Status st = lab::checkConninfo(lab.database); !st.ok) {
      diag.error(t->get("database")->source(), st.message);
    }
  }
  lab.password_file = resolve(base_dir, strField(*t, "password_file", diag, false).value_or(""));
  lab.mirror_samples = io::boolField(*t, "mirror_samples", diag).value_or(false);
  b.lab = lab;
}

// [explain]: follow_up = "off" | "propose" | "queue".
void parseExplain(const toml::table& root, BenchConfig& b, Diagnostics& diag) {
  const toml::table* t = subTable(root, "explain", diag, false);
  if (t == nullptr) return;
  checkKeys(*t, {"follow_up"}, "[explain]", diag);
  const auto v = strField(*t, "follow_up", diag, false);
  if (!v) return;
  for (FollowUpPolicy p :
       {FollowUpPolicy::kOff, FollowUpPolicy::kPropose, FollowUpPolicy::kQueue}) {
    if (*v == followUpPolicyName(p)) {
      b.explain.follow_up = p;
      return;
    }
  }
  diag.error(t->get("follow_up")->source(),
             "follow_up must be \"off\", \"propose\" or \"queue\", not \"" + *v + "\"");
}

}  // namespace

const char* followUpPolicyName(FollowUpPolicy p) {
  switch (p) {
    case FollowUpPolicy::kOff:
      return "off";
    case FollowUpPolicy::kPropose:
      return "propose";
    case FollowUpPolicy::kQueue:
      return "queue";
  }
  return "?";
}

std::optional<BenchConfig> parseBenchFile(std::string_view text, std::string_view file_name,
                                          const std::string& base_dir, Diagnostics& diag) {
  auto root = io::parseToml(text, diag);
  if (!root) return std::nullopt;
  BenchConfig b;
  b.file = std::string(file_name);
  checkKeys(*root,
            {"bench", "site", "table", "chamber", "imu", "safety", "control", "acceptance", "lab",
             "explain"},
            "the top level", diag);
  parseBenchTable(*root, base_dir, b, diag);
  parseSite(*root, b, diag);
  parseTable(*root, base_dir, b, diag);
  parseChamber(*root, base_dir, b, diag);
  parseImu(*root, base_dir, b, diag);
  parseSafety(*root, b, diag);
  parseControl(*root, base_dir, b, diag);
  parseAcceptance(*root, b, diag);
  parseLab(*root, base_dir, b, diag);
  parseExplain(*root, b, diag);
  if (!diag.ok()) return std::nullopt;
  return b;
}

std::optional<BenchConfig> loadBenchFile(const std::string& path, Diagnostics& diag) {
  auto text = io::readTextFile(path, "bench", diag);
  if (!text) return std::nullopt;
  return parseBenchFile(*text, path, fs::path(path).parent_path().string(), diag);
}

}  // namespace imubench::daemon
