#include "calib/sensor_model.h"

namespace imubench::calib {

Mat3 misalignmentMatrix(const Misalignment& m) {
  Mat3 M;
  M << 1.0, m.xy, -m.xz,  //
      -m.yx, 1.0, m.yz,   //
      m.zx, -m.zy, 1.0;
  return M;
}

Vec3 TriadModel::reading(const Vec3& in) const {
  return scale.cwiseProduct(M() * in - bias);
}

Vec3 TriadModel::input(const Vec3& r) const {
  // reading = S (M in - b)  =>  in = M^-1 (S^-1 reading + b). M is near identity: LU is exact
  // to rounding and never singular for physical misalignments.
  return M().partialPivLu().solve(r.cwiseQuotient(scale) + bias);
}

}  // namespace imubench::calib
