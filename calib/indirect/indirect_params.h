// Parameter layout of the navigation-based (indirect) calibration: the model's own blocks
// (calib/model/sensor_equation.h for each triad, calib/model/table_chain.h's axes block for
// the table), with their named offsets, laid out [accel block | gyro block | table block].
//
// Frame: the "input" of the triads is resolved in the gyro-referenced platform frame P (see
// docs/calibration.md): the frame the table's orthogonal axes define, so the estimated
// misalignments of BOTH triads absorb the device mounting on the platform in one definite way.
#pragma once

#include <array>
#include <string>

#include "calib/model/sensor_equation.h"
#include "calib/model/table_chain.h"
#include "calib/table_model.h"
#include "nav/rotation.h"

namespace imubench::calib::indirect {

using model::kBias;
using model::kMis;
using model::kMisXY;
using model::kMisXZ;
using model::kMisYX;
using model::kMisYZ;
using model::kMisZX;
using model::kMisZY;
using model::kScale;
using model::kTriadSize;

using model::kNonorthInnerY;
using model::kNonorthMiddleX;
using model::kNonorthMiddleY;
using model::kTiltX;
using model::kTiltY;
inline constexpr int kTableSize = model::kTableAxesSize;

// Total parameter count and the global index helpers used for naming (information matrix,
// covariance, observability flags): [accel block | gyro block | table block].
inline constexpr int kAccelOffset = 0;
inline constexpr int kGyroOffset = kTriadSize;
inline constexpr int kTableOffset = 2 * kTriadSize;
inline constexpr int kParamCount = 2 * kTriadSize + kTableSize;

// "accel.scale.x", "gyro.misalignment.zy", "table.base_tilt.y", ...
std::string parameterName(int global_index);

using model::compensationAffine;
using model::Mat3T;
using model::Vec3T;

// Attitude C_LP of the platform frame P (the inner gimbal: z = the inner axis) for the encoder
// angles, with the base tilt and nonorthogonality of the table block: the model's chain
// (calib/model/table_chain.h) without the mounting and with the encoder zeros absorbed (the
// outer zero of a two-axis table into the tilt, the inner zero into the frame P, the
// three-axis middle zero into middle_x).
template <typename T>
Mat3T<T> platformAttitude(const TableGeometry& g, const TableAngles& a, const T* table) {
  return model::tableAttitude(g.kind, g.outer_axis_heading_rad,
                              model::chainErrors<T>(g.kind, table, nullptr), T(a.outer),
                              T(a.middle), T(a.inner));
}

// input = M^-1 (diag(scale)^-1 reading + bias) for a measured (constant) reading.
template <typename T>
Vec3T<T> compensate(const T* triad, const Vec3& reading) {
  return model::input(triad, Vec3T<T>(reading.cast<T>()));
}

}  // namespace imubench::calib::indirect
