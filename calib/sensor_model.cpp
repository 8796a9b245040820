#include "calib/sensor_model.h"

namespace imubench::calib {

Mat3 misalignmentMatrix(const Misalignment& m) {
  const double mis[model::kMisCount] = {m.xy, m.xz, m.yx, m.yz, m.zx, m.zy};
  return model::misalignmentMatrix(mis);
}

std::array<double, model::kTriadSize> TriadModel::block() const {
  std::array<double, model::kTriadSize> b{};
  for (int i = 0; i < 3; ++i) {
    b[static_cast<std::size_t>(model::kScale + i)] = scale[i];
    b[static_cast<std::size_t>(model::kBias + i)] = bias[i];
  }
  const double m[model::kMisCount] = {mis.xy, mis.xz, mis.yx, mis.yz, mis.zx, mis.zy};
  for (int k = 0; k < model::kMisCount; ++k) b[static_cast<std::size_t>(model::kMis + k)] = m[k];
  return b;
}

TriadModel TriadModel::fromBlock(const double* b) {
  TriadModel t;
  t.scale = model::scaleOf(b);
  t.bias = model::biasOf(b);
  t.mis = misalignmentFrom(b + model::kMis);
  return t;
}

Vec3 TriadModel::reading(const Vec3& in) const {
  return model::reading(block().data(), in);
}

Vec3 TriadModel::input(const Vec3& r) const {
  return model::input(block().data(), r);
}

}  // namespace imubench::calib
