#include "tools/cli_run_report.h"

#include <algorithm>
#include <cstdio>

namespace imubench::tools {
namespace {

// Index range of the samples whose interval (t_prev, t] lies inside [t0, t1].
std::pair<size_t, size_t> samplesWithin(const nav::ImuSamples& imu, double t0, double t1) {
  const auto cmp = [](const nav::ImuSample& s, double t) { return s.t < t; };
  auto b = std::lower_bound(imu.begin(), imu.end(), t0, cmp);
  // The first sample's interval starts after t0 only if its predecessor's stamp is >= t0.
  if (b != imu.end()) ++b;
  auto e = std::upper_bound(imu.begin(), imu.end(), t1,
                            [](double t, const nav::ImuSample& s) { return t < s.t; });
  if (b > e) b = e;
  return {static_cast<size_t>(b - imu.begin()), static_cast<size_t>(e - imu.begin())};
}

}  // namespace

std::optional<Vec3> meanSpecificForce(const nav::ImuSamples& imu, double t0, double t1) {
  const auto [b, e] = samplesWithin(imu, t0, t1);
  if (b >= e || b == 0) return std::nullopt;
  Vec3 dv = Vec3::Zero();
  for (size_t i = b; i < e; ++i) dv += imu[i].dvel;
  const double dt = imu[e - 1].t - imu[b - 1].t;
  if (!(dt > 0.0)) return std::nullopt;
  return dv / dt;
}

std::vector<RotationSummary> summarizeRotations(const std::vector<calib::Segment>& segments,
                                                const nav::ImuSamples& imu) {
  std::vector<RotationSummary> out;
  for (size_t i = 0; i < segments.size(); ++i) {
    const auto& s = segments[i];
    if (s.kind != calib::SegmentKind::kRotate) continue;
    RotationSummary r;
    r.label = s.label;
    r.axis = s.axis;
    r.angle_rad = s.angle;
    r.duration_s = s.t1 - s.t0;
    // Gyro angle over every sample touching the rotation: the table is still on both sides,
    // so the extra fraction of a sample only adds Earth rate (~1e-7 deg).
    const auto cmp = [](const nav::ImuSample& x, double t) { return x.t < t; };
    auto b = std::lower_bound(imu.begin(), imu.end(), s.t0, cmp);
    auto e = std::lower_bound(imu.begin(), imu.end(), s.t1, cmp);
    if (e != imu.end()) ++e;
    for (auto it = b; it < e; ++it) r.gyro_angle_rad += it->dtheta;
    for (size_t j = i; j-- > 0;) {
      if (segments[j].kind == calib::SegmentKind::kStatic) {
        r.f_before = meanSpecificForce(imu, segments[j].t0, segments[j].t1);
        break;
      }
    }
    for (size_t j = i + 1; j < segments.size(); ++j) {
      if (segments[j].kind == calib::SegmentKind::kStatic) {
        r.f_after = meanSpecificForce(imu, segments[j].t0, segments[j].t1);
        break;
      }
    }
    out.push_back(std::move(r));
  }
  return out;
}

std::string formatRotationTable(const std::vector<RotationSummary>& runs,
                                const std::vector<std::string>& axis_names) {
  std::string out;
  char buf[512];
  std::snprintf(buf, sizeof(buf), "%3s %-22s %-6s %8s %7s  %-33s  %-27s  %-27s\n", "run", "label",
                "axis", "angle", "time", "gyro angle x y z (deg)", "f before x y z (m/s^2)",
                "f after x y z (m/s^2)");
  out += buf;
  std::snprintf(buf, sizeof(buf), "%3s %-22s %-6s %8s %7s\n", "", "", "", "(deg)", "(s)");
  out += buf;
  auto vec = [](const std::optional<Vec3>& v) {
    char b[96];
    if (!v) return std::string("          -        -        -");
    std::snprintf(b, sizeof(b), "%9.5f %9.5f %9.5f", v->x(), v->y(), v->z());
    return std::string(b);
  };
  int n = 0;
  for (const auto& r : runs) {
    const std::string axis = r.axis >= 0 && static_cast<size_t>(r.axis) < axis_names.size()
                                 ? axis_names[static_cast<size_t>(r.axis)]
                                 : "?";
    const Vec3 g = r.gyro_angle_rad * kRadToDeg;
    std::snprintf(buf, sizeof(buf),
                  "%3d %-22.22s %-6s %+8.2f %7.2f  %+10.5f %+10.5f %+10.5f  %s  %s\n", ++n,
                  r.label.c_str(), axis.c_str(), r.angle_rad * kRadToDeg, r.duration_s, g.x(),
                  g.y(), g.z(), vec(r.f_before).c_str(), vec(r.f_after).c_str());
    out += buf;
  }
  return out;
}

}  // namespace imubench::tools
