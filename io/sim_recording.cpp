#include "io/sim_recording.h"

namespace imubench::io {

Recording recordingFromSimulation(const calib::Simulation& sim, const nav::Site& site,
                                  const RecordingIdentity& id) {
  Recording rec;
  rec.latitude_deg = site.latitude_rad * kRadToDeg;
  rec.height_m = site.height_m;
  rec.gravity_mps2 = site.gravity_mps2;
  rec.imu_serial = id.imu_serial;
  rec.imu_rate_hz = id.imu_rate_hz;
  rec.table_kind = sim.kind;
  if (sim.kind == calib::TableKind::kTwoAxis) {
    rec.outer_axis_heading_deg = id.outer_axis_heading_rad * kRadToDeg;
  }
  rec.imu = sim.imu;
  rec.table.reserve(sim.table.size());
  const bool two = sim.kind == calib::TableKind::kTwoAxis;
  for (const auto& s : sim.table) {
    TableSample t;
    t.t = s.t;
    if (two) {
      t.angles_deg = {s.angles.outer * kRadToDeg, s.angles.inner * kRadToDeg, 0.0};
    } else {
      t.angles_deg = {s.angles.outer * kRadToDeg, s.angles.middle * kRadToDeg,
                      s.angles.inner * kRadToDeg};
    }
    rec.table.push_back(t);
  }
  rec.segments = sim.segments;
  return rec;
}

std::vector<calib::TableSample> tableSamples(const Recording& rec) {
  std::vector<calib::TableSample> out;
  out.reserve(rec.table.size());
  for (const TableSample& s : rec.table) {
    const std::vector<double> a = tableAnglesRad(rec.table_kind, s);
    out.push_back({s.t, calib::tableAnglesFromAxes(rec.table_kind, a.data())});
  }
  return out;
}

calib::TableGeometry geometryOf(const Recording& rec) {
  calib::TableGeometry g;
  g.kind = rec.table_kind;
  g.outer_axis_heading_rad = rec.outerAxisHeadingDeg() * kDegToRad;
  return g;
}

}  // namespace imubench::io
