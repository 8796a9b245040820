#include "daemon/thermal_points.h"

#include <cmath>
#include <optional>
#include <utility>

#include "calib/bench_truth.h"
#include "daemon/run_calibration.h"

namespace imubench::daemon {
namespace {

// Mean of the finite values of `get` over the rows with t in [t0, t1]; nullopt when none.
template <class Row, class Get>
std::optional<double> meanOver(const std::vector<Row>& rows, double t0, double t1, Get get) {
  double sum = 0.0;
  long n = 0;
  for (const Row& r : rows) {
    if (r.t < t0 || r.t > t1 || !std::isfinite(get(r))) continue;
    sum += get(r);
    ++n;
  }
  if (n == 0) return std::nullopt;
  return sum / static_cast<double>(n);
}

// The rows with t in [t0, t1].
template <class Row>
std::vector<Row> cropped(const std::vector<Row>& rows, double t0, double t1) {
  std::vector<Row> out;
  for (const Row& r : rows) {
    if (r.t >= t0 && r.t <= t1) out.push_back(r);
  }
  return out;
}

void calibratePoint(const io::Recording& rec, const std::vector<calib::Segment>& body,
                    const std::optional<calib::TableErrors>& known_table_errors,
                    PointCalibration* p) {
  p->segments = static_cast<int>(body.size());
  p->t0 = body.front().t0;
  p->t1 = body.back().t1;
  const auto imu_t = meanOver(rec.imu, p->t0, p->t1, [](const auto& s) { return s.temp_c; });
  const auto air_t = meanOver(rec.chamber, p->t0, p->t1, [](const auto& s) { return s.temp_c; });
  const auto air_sp =
      meanOver(rec.chamber, p->t0, p->t1, [](const auto& s) { return s.setpoint_c; });
  if (air_sp) p->setpoint_c = *air_sp;
  p->temperature_source = imu_t ? "imu" : air_t ? "chamber" : "setpoint";
  p->temperature_c = imu_t ? *imu_t : air_t ? *air_t : p->setpoint_c;
  io::Recording sub = rec;  // meta data, site, table kind
  sub.imu = cropped(rec.imu, p->t0, p->t1);
  sub.table = cropped(rec.table, p->t0, p->t1);
  sub.chamber = cropped(rec.chamber, p->t0, p->t1);
  sub.segments = body;
  const RunCalibration c =
      calibrateRun(plans::CalibrationMethod::kDirect, sub, nullptr, known_table_errors);
  p->status = c.status;
  if (c.status.ok) p->coefficients = calib::toJson(c.coefficients);
}

}  // namespace

bool hasTemperaturePoints(const std::vector<RunStep>& steps) {
  for (const RunStep& s : steps) {
    if (s.kind == calib::SegmentKind::kSoak) return true;
  }
  return false;
}

std::vector<PointCalibration> calibrateTemperaturePoints(
    const io::Recording& rec, const std::optional<calib::TableErrors>& known_table_errors) {
  std::vector<PointCalibration> out;
  std::optional<PointCalibration> open;
  std::vector<calib::Segment> body;
  auto close = [&]() {
    if (open && !body.empty()) {
      calibratePoint(rec, body, known_table_errors, &*open);
      out.push_back(std::move(*open));
    }
    open.reset();
    body.clear();
  };
  for (const calib::Segment& seg : rec.segments) {
    if (seg.kind == calib::SegmentKind::kSoak) {
      close();
      open.emplace();
      open->label = seg.label;
      open->setpoint_c = seg.setpoint_c;
    } else if (open) {
      body.push_back(seg);
    }
  }
  close();
  return out;
}

nlohmann::json pointJson(const PointCalibration& p) {
  nlohmann::json j = {{"point", p.label},
                      {"setpoint_c", p.setpoint_c},
                      {"temperature_c", p.temperature_c},
                      {"temperature_source", p.temperature_source},
                      {"t0", p.t0},
                      {"t1", p.t1},
                      {"segments", p.segments},
                      {"method", "direct"},
                      {"ok", p.status.ok}};
  if (p.status.ok) {
    j["coefficients"] = p.coefficients;
  } else {
    j["error"] = p.status.message;
  }
  return j;
}

}  // namespace imubench::daemon
