// The sensor model of one IMU in double precision: named fields for eq. (1) of interchange.md,
// which calib/model/sensor_equation.h states once (signs, frames, the exact inverse); reading()
// and input() evaluate it there. Scale is the total factor (about 1.0), not a deviation.
// Extra physics (temperature, asymmetry, g-sensitivity...) lives in calib/effects.h.
#pragma once

#include <array>

#include "calib/model/sensor_equation.h"
#include "nav/rotation.h"

namespace imubench::calib {

// The six misalignment angles of eq. (1), rad. Names follow interchange.md's JSON keys.
struct Misalignment {
  double xy = 0.0;
  double xz = 0.0;
  double yx = 0.0;
  double yz = 0.0;
  double zx = 0.0;
  double zy = 0.0;
};

// From six misalignments in the model's order (calib/model/sensor_equation.h kMisEntries).
inline Misalignment misalignmentFrom(const double* m) {
  return {m[model::kMisXY], m[model::kMisXZ], m[model::kMisYX],
          m[model::kMisYZ], m[model::kMisZX], m[model::kMisZY]};
}

// M of eq. (1) for the given misalignments.
Mat3 misalignmentMatrix(const Misalignment& m);

// One triad (three accelerometers or three gyros).
struct TriadModel {
  Vec3 scale{1.0, 1.0, 1.0};  // total scale factor per axis
  Vec3 bias = Vec3::Zero();   // m/s^2 or rad/s, subtracted before scaling
  Misalignment mis;           // rad

  Mat3 M() const { return misalignmentMatrix(mis); }
  // Noise-free reading for an input (eq. 1 with noise = 0).
  Vec3 reading(const Vec3& input) const;
  // The input that produces this reading: the exact inverse of reading() (M^-1 applied).
  Vec3 input(const Vec3& reading) const;

  // The model's parameter block (calib/model/sensor_equation.h offsets) and back.
  std::array<double, model::kTriadSize> block() const;
  static TriadModel fromBlock(const double* block);
};

struct SensorModel {
  TriadModel accel;  // input: specific force, m/s^2
  TriadModel gyro;   // input: w_IB_B, rad/s
};

}  // namespace imubench::calib
