// Test-only motions for the navigation-based calibration tests, built directly as
// calib::Motion (exact trapezoid profiles): the seed's two-axis 12-run schedule and a
// three-axis schedule. The bundled plan files (plans/library/) are tested through the
// plans/ expansion in test_indirect_plans.cpp; these keep the calibrator's tests independent.
#pragma once

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "calib/model/motion.h"
#include "nav/rotation.h"

namespace imubench::calib::testing {

class MotionBuilder {
 public:
  explicit MotionBuilder(TableKind kind, double rate = 10.0 * kDegToRad,
                         double accel = 5.0 * kDegToRad)
      : rate_(rate), accel_(accel) {
    m_.kind = kind;
    m_.axes.resize(static_cast<std::size_t>(axisCount(kind)));
    angles_.assign(m_.axes.size(), 0.0);
    for (auto& a : m_.axes) a.append({0.0, 0.0, 0.0, 0.0});
  }

  void hold(double seconds, const std::string& label) {
    push(SegmentKind::kStatic, t_, t_ + seconds, label, -1, 0.0);
    t_ += seconds;
  }
  // Moves every axis to the target angles (deg, absolute), all starting together.
  void moveTo(const std::vector<double>& target_deg, const std::string& label) {
    double longest = 0.0;
    for (std::size_t i = 0; i < angles_.size(); ++i) {
      const double delta = target_deg[i] * kDegToRad - angles_[i];
      longest = std::max(longest, profile(i, t_, delta));
    }
    if (longest > 0.0) push(SegmentKind::kMove, t_, t_ + longest, label, -1, 0.0);
    t_ += longest;
  }
  void rotate(int axis, double delta_deg, const std::string& label) {
    const double d = profile(static_cast<std::size_t>(axis), t_, delta_deg * kDegToRad);
    push(SegmentKind::kRotate, t_, t_ + d, label, axis, delta_deg * kDegToRad);
    t_ += d;
  }
  Motion finish() {
    m_.duration = t_;
    return m_;
  }

 private:
  // Trapezoid (or triangle) from rest to rest; returns its duration.
  double profile(std::size_t axis, double t0, double delta) {
    if (delta == 0.0) return 0.0;
    const double s = delta > 0 ? 1.0 : -1.0;
    const double d = std::abs(delta);
    double ta = rate_ / accel_;
    double tc = 0.0;
    double peak = rate_;
    if (accel_ * ta * ta > d) {
      ta = std::sqrt(d / accel_);
      peak = accel_ * ta;
    } else {
      tc = (d - accel_ * ta * ta) / rate_;
    }
    const double a0 = angles_[axis];
    AxisTrajectory& tr = m_.axes[axis];
    tr.append({t0, a0, 0.0, s * accel_});
    const double a1 = a0 + s * 0.5 * accel_ * ta * ta;
    if (tc > 0.0) tr.append({t0 + ta, a1, s * peak, 0.0});
    const double a2 = a1 + s * peak * tc;
    tr.append({t0 + ta + tc, a2, s * peak, -s * accel_});
    angles_[axis] = a0 + delta;
    tr.append({t0 + 2 * ta + tc, angles_[axis], 0.0, 0.0});
    return 2 * ta + tc;
  }
  void push(SegmentKind k, double t0, double t1, const std::string& label, int axis, double angle) {
    Segment s;
    s.t0 = t0;
    s.t1 = t1;
    s.kind = k;
    s.label = label;
    s.axis = axis;
    s.angle = angle;
    m_.segments.push_back(s);
  }

  Motion m_;
  std::vector<double> angles_;
  double t_ = 0.0;
  double rate_;
  double accel_;
};

// Two-axis (C_LB = Rx(outer) Rz(inner)) 12-run schedule: each IMU axis along the outer axis
// (x: inner 0/180, y: inner 90/270, turned by the outer axis) or made horizontal by the outer
// axis (z: outer +90/-90, turned by the inner axis), two placements differing by 90 deg about
// the axis, and in each placement +180 then -180.
inline Motion twoAxis12Run(double hold_s = 60.0) {
  MotionBuilder b(TableKind::kTwoAxis);
  struct Placement {
    double outer, inner;
    int axis;
    const char* name;
  };
  const Placement p[6] = {{0, 0, 0, "x1"},    {90, 180, 0, "x2"}, {0, 90, 0, "y1"},
                          {90, 270, 0, "y2"}, {90, 0, 1, "z1"},   {-90, 90, 1, "z2"}};
  int run = 0;
  for (const Placement& pl : p) {
    b.moveTo({pl.outer, pl.inner}, std::string("to-") + pl.name);
    b.hold(hold_s, std::string("hold-") + pl.name + "-a");
    for (double dir : {180.0, -180.0}) {
      ++run;
      b.rotate(pl.axis, dir, "run" + std::to_string(run) + "-" + pl.name);
      b.hold(hold_s, "hold-run" + std::to_string(run));
    }
  }
  return b.finish();
}

// Three-axis (C_LB = Rz(outer) Rx(middle) Rz(inner)) schedule: 180-degree turns about the
// horizontal middle axis (x, y along it by the inner axis) and about the inner axis made
// horizontal by the middle axis (z), at two outer headings, without remounting.
inline Motion threeAxisIndirect(double hold_s = 60.0) {
  MotionBuilder b(TableKind::kThreeAxis);
  struct Placement {
    double outer, middle, inner;
    int axis;
    const char* name;
  };
  const Placement p[6] = {{0, 0, 0, 1, "x1"},    {90, 90, 0, 1, "x2"}, {0, 0, 90, 1, "y1"},
                          {90, 90, 90, 1, "y2"}, {0, 90, 0, 2, "z1"},  {90, -90, 90, 2, "z2"}};
  int run = 0;
  for (const Placement& pl : p) {
    b.moveTo({pl.outer, pl.middle, pl.inner}, std::string("to-") + pl.name);
    b.hold(hold_s, std::string("hold-") + pl.name + "-a");
    for (double dir : {180.0, -180.0}) {
      ++run;
      b.rotate(pl.axis, dir, "run" + std::to_string(run) + "-" + pl.name);
      b.hold(hold_s, "hold-run" + std::to_string(run));
    }
  }
  return b.finish();
}

}  // namespace imubench::calib::testing
