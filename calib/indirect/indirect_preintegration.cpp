#include "calib/indirect/indirect_preintegration.h"

namespace imubench::calib::indirect {

RunPreintegration preintegrateRun(std::span<const nav::ImuSample> samples, double t_start,
                                  const Mat3& C_LB_start, const double* gyro, const Vec3& w_ie_L) {
  RunPreintegration out;
  compensationAffine(gyro, &out.G0, &out.h0);
  Quat q_BtoL(C_LB_start);
  q_BtoL.normalize();
  Vec3 dth_prev = Vec3::Zero();
  double t_prev = t_start;
  for (const nav::ImuSample& s : samples) {
    const double dt = s.t - t_prev;
    t_prev = s.t;
    const Vec3 dth = out.G0 * s.dtheta + out.h0 * dt;
    const Vec3 phi = dth + dth_prev.cross(dth) / 12.0;
    dth_prev = dth;
    const Mat3 C_before = q_BtoL.toRotationMatrix();
    q_BtoL = quatFromRotationVector(-w_ie_L * dt) * q_BtoL * quatFromRotationVector(phi);
    q_BtoL.normalize();
    const Mat3 C_mid = 0.5 * (C_before + q_BtoL.toRotationMatrix());
    for (int j = 0; j < 3; ++j) out.K[j] += C_mid * s.dtheta[j];
    out.H += C_mid * dt;
    out.duration_s += dt;
    ++out.samples;
  }
  out.C_LB_end0 = q_BtoL.toRotationMatrix();
  return out;
}

}  // namespace imubench::calib::indirect
