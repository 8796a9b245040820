// Every effect unit of the registry (calib/model/effects.h) differentiated with ceres::Jet
// against central differences of the same templates in double, with respect to the effect's
// (real) parameters and its inputs: one test per effect id. Each probe runs the unit through
// the registry's own dispatch where there is one (sensorReadings, addTableEffects,
// trueJointStates), so a unit whose Jet instantiation differs from its double one, or that the
// dispatch skips, fails here.
#include <gtest/gtest.h>

#include <map>
#include <ostream>
#include <type_traits>
#include <vector>

#include "calib/effects.h"
#include "calib/model/bench_physics.h"
#include "calib/model/effects.h"
#include "tests/calib/derivative_check.h"

namespace imubench::calib {
// Test names print the effect's id.
void PrintTo(EffectId id, std::ostream* os) {
  *os << effectName(id);
}
}  // namespace imubench::calib

namespace imubench::calib::model {
namespace {

constexpr int kJetSize = 64;

// A nonzero sample of every effect's flat parameters (discrete ones valid).
const std::map<EffectId, std::vector<double>>& sampleParams() {
  static const std::map<EffectId, std::vector<double>> m = {
      {EffectId::kLeverArm, {0.05, -0.03, 0.12}},
      {EffectId::kTimeDelay, {0.004}},
      {EffectId::kGyroGSensitivity, {1e-5, -2e-5, 3e-5, -4e-5, 5e-5, -6e-5, 7e-5, -8e-5, 9e-5}},
      {EffectId::kThermalBias, {1e-4, -2e-4, 3e-4, 1e-6, -2e-6, 3e-6, 22.0}},
      {EffectId::kThermalScale, {1e-4, -2e-4, 3e-4, 2e-5, -1e-5, 3e-5, 22.0}},
      {EffectId::kScaleAsymmetry, {1e-3, -2e-3, 3e-3}},
      {EffectId::kAccelK2, {1e-4, -2e-4, 3e-4}},
      {EffectId::kLatitudeError, {0.01}},
      {EffectId::kGravityError, {2e-3}},
      {EffectId::kSizeEffect, {0.01, 0.02, -0.015, -0.02, 0.01, 0.03}},
      {EffectId::kAccelDelay, {-0.002}},
      {EffectId::kAngleHarmonic, {kTableAxisMiddle, 2.0, 3e-4, -2e-4}},
      {EffectId::kBiasInstability, {1e-4, 2e-4, 3e-4, 1e-6, 2e-6, 3e-6, 50.0}},
      {EffectId::kBaseTilt, {1e-4, -2e-4}},
      {EffectId::kNonorthogonality, {3e-4, -1e-4, 2e-4}},
      {EffectId::kEncoderZero, {1e-4, -3e-4, 2e-4}},
      {EffectId::kMounting, {-2e-4, 1e-4}},
  };
  return m;
}

bool isDiscrete(const ParamSpec& p) {
  return p.kind != ParamKind::kReal;
}

// The effect's flat vector split into the real parameters (differentiated) and the rest.
std::vector<double> realParams(EffectId id) {
  std::vector<double> out;
  const std::vector<double>& v = sampleParams().at(id);
  std::size_t k = 0;
  for (const ParamSpec& p : paramSpecs(id)) {
    for (int e = 0; e < paramSize(p.shape); ++e, ++k) {
      if (!isDiscrete(p)) out.push_back(v[k]);
    }
  }
  return out;
}

// The full parameter block of id in T: real parameters from x, discrete ones as constants.
template <typename T>
std::vector<T> blockFrom(EffectId id, const T* x) {
  std::vector<T> block;
  const std::vector<double>& v = sampleParams().at(id);
  std::size_t k = 0, j = 0;
  for (const ParamSpec& p : paramSpecs(id)) {
    for (int e = 0; e < paramSize(p.shape); ++e, ++k) {
      block.push_back(isDiscrete(p) ? T(v[k]) : x[j++]);
    }
  }
  return block;
}

template <typename T>
EffectBlocks<T> only(EffectId id, const std::vector<T>& block) {
  EffectBlocks<T> fx{};
  fx[static_cast<std::size_t>(id)] = block.data();
  return fx;
}

// A probe's point x = [the unit's real parameters | inputs] and the number n of parameters.
struct ProbePoint {
  std::vector<double> x;
  int n = 0;
};
ProbePoint probePoint(EffectId id, const std::vector<double>& inputs) {
  ProbePoint pt{realParams(id), 0};
  pt.n = static_cast<int>(pt.x.size());
  pt.x.insert(pt.x.end(), inputs.begin(), inputs.end());
  return pt;
}

// The probe's function of x: body(block, in) with the unit's full parameter block and the
// inputs (x after the n parameters), both in the scalar of x.
template <class Body>
auto probeFunction(EffectId id, int n, const Body& body) {
  return [id, n, body](const auto* p) {
    using T = std::remove_cv_t<std::remove_pointer_t<decltype(p)>>;
    const std::vector<T> block = blockFrom(id, p);
    return body(block, static_cast<const T*>(p + n));
  };
}

// Reading stages: x = [params | f_B, w_IB_B, w_LB_B, wdot_LB_B, temp | accel, gyro triads].
void readingProbe(EffectId id) {
  std::vector<double> inputs = {0.5, -0.3, 9.79, 1e-3, 0.2,  0.5, 0.1,
                                0.2, 0.5,  0.1,  0.3,  -0.2, 35.0};
  const std::vector<double> triad = {1.0002, 0.9997, 1.0001, 0.01,  -0.02, 0.015,
                                     1e-3,   -2e-3,  3e-3,   -1e-3, 2e-3,  -3e-3};
  inputs.insert(inputs.end(), triad.begin(), triad.end());
  inputs.insert(inputs.end(), triad.begin(), triad.end());
  const auto [x, n] = probePoint(id, inputs);
  const auto f = probeFunction(id, n, [id]<typename T>(const std::vector<T>& block, const T* in) {
    ReadingState<T> s;
    s.f_B = vec3At(in);
    s.w_IB_B = vec3At(in + 3);
    s.w_LB_B = vec3At(in + 6);
    s.wdot_LB_B = vec3At(in + 9);
    s.temp_c = in[12];
    sensorReadings(in + 13, in + 13 + kTriadSize, only(id, block), &s);
    std::vector<T> out;
    append(&out, s.accel);
    append(&out, s.gyro);
    return out;
  });
  expectJetMatchesDifferences<kJetSize>(f, x, 1e-7, n);
  // The effect changes the readings (it is applied by the registry's forward pass).
  std::vector<double> off = x;
  const std::vector<double> on_r = f(x.data());
  for (int k = 0; k < n; ++k) off[static_cast<std::size_t>(k)] = 0.0;
  // t_ref_c alone does nothing; zero every real parameter, so the term vanishes.
  EXPECT_NE(on_r, f(off.data()));
}

// Smooth two-axis motion sampled at time t: C_LB, f_B, w_IB_B of the chain and bench physics.
template <typename T>
void physicsAtTime(const T& t, std::vector<T>* out) {
  const T angle_o = T(0.3) + T(0.4) * t + T(0.5) * T(0.2) * t * t;
  const T angle_i = T(-0.7) + T(0.9) * t;
  const ChainFactors<T> factors = chainFactors(TableKind::kTwoAxis, 1.2, ChainErrors<T>{});
  const ChainKinematics<T> k =
      chainKinematics(factors, JointState<T>{angle_o, T(0.4) + T(0.2) * t, T(0.2)}, JointState<T>{},
                      JointState<T>{angle_i, T(0.9), T(0.0)});
  const Physics<T> ph = benchPhysics(k, T(9.81), Vec3T<T>(T(0.0), T(4e-5), T(6e-5)));
  append(out, ph.f_B);
  append(out, ph.w_IB_B);
}

// Time stages: x = [tau | stamp]; the physics at the unit's sample time.
void timeProbe(EffectId id) {
  const auto [x, n] = probePoint(id, {1.3});
  const auto body = [id]<typename T>(const std::vector<T>& block, const T* in) {
    const T t = id == EffectId::kTimeDelay ? effects::TimeDelay::sampleTime(block.data(), in[0])
                                           : effects::AccelDelay::sampleTime(block.data(), in[0]);
    std::vector<T> out{t};
    physicsAtTime(t, &out);
    return out;
  };
  expectJetMatchesDifferences<kJetSize>(probeFunction(id, n, body), x, 1e-7, n + 1);
}

// Site stages: x = [parameter | assumed value]; the true value and what it feeds.
void siteProbe(EffectId id) {
  const auto [x, n] = probePoint(id, {id == EffectId::kLatitudeError ? 0.97 : 9.81});
  const auto body = [id]<typename T>(const std::vector<T>& block, const T* in) {
    using std::cos;
    using std::sin;
    std::vector<T> out;
    if (id == EffectId::kLatitudeError) {
      const T lat = effects::LatitudeError::trueValue(block.data(), in[0]);
      out = {lat, cos(lat), sin(lat)};
    } else {
      const T g = effects::GravityError::trueValue(block.data(), in[0]);
      ChainKinematics<T> k;
      k.C_LB = smallRotation(Vec3T<T>(T(0.1), T(-0.2), T(0.3)));
      const Physics<T> ph = benchPhysics(k, g, Vec3T<T>::Zero().eval());
      out = {g};
      append(&out, ph.f_B);
    }
    return out;
  };
  expectJetMatchesDifferences<kJetSize>(probeFunction(id, n, body), x, 1e-7, n + 1);
}

// Table stages: x = [params | encoder angles, rates, accelerations of a three-axis table
// (every table parameter acts there)]; C_LB, w_LB_B, wdot_LB_B of the chain with the errors.
void tableProbe(EffectId id) {
  const auto [x, n] = probePoint(id, {0.7, -1.1, 2.3, 0.4, -0.3, 0.9, 0.2, 0.5, -0.6});
  const auto body = [id]<typename T>(const std::vector<T>& block, const T* a) {
    std::array<T, kTableAxesSize> axes{};
    std::array<T, kTableDeviceSize> device{};
    axes.fill(T(0.0));
    device.fill(T(0.0));
    addTableEffects(only(id, block), axes.data(), device.data());
    const TableKind kind = TableKind::kThreeAxis;
    const ChainErrors<T> e = chainErrors(kind, axes.data(), device.data());
    const ChainKinematics<T> k =
        chainKinematics(chainFactors(kind, 0.0, e), JointState<T>{a[0] + e.zero_outer, a[3], a[6]},
                        JointState<T>{a[1] + e.zero_middle, a[4], a[7]},
                        JointState<T>{a[2] + e.zero_inner, a[5], a[8]});
    std::vector<T> out;
    append(&out, k.C_LB);
    append(&out, k.w_LB_B);
    append(&out, k.wdot_LB_B);
    return out;
  };
  expectJetMatchesDifferences<kJetSize>(probeFunction(id, n, body), x, 1e-7, n);
}

// Angle stages: x = [real params | encoder angle, rate, acceleration of each axis]; the true
// joint states and the three-axis chain's kinematics from them.
void angleProbe(EffectId id) {
  const auto [x, n] = probePoint(id, {0.7, 0.4, 0.2, -1.1, -0.3, 0.5, 2.3, 0.9, -0.6});
  const auto body = [id]<typename T>(const std::vector<T>& block, const T* a) {
    std::array<JointState<T>, 3> joints = {JointState<T>{a[0], a[1], a[2]},
                                           JointState<T>{a[3], a[4], a[5]},
                                           JointState<T>{a[6], a[7], a[8]}};
    trueJointStates(only(id, block), &joints);
    const ChainKinematics<T> k =
        chainKinematics(chainFactors(TableKind::kThreeAxis, 0.0, ChainErrors<T>{}), joints[0],
                        joints[1], joints[2]);
    std::vector<T> out;
    for (const JointState<T>& j : joints) out.insert(out.end(), {j.angle, j.rate, j.accel});
    append(&out, k.w_LB_B);
    append(&out, k.wdot_LB_B);
    return out;
  };
  expectJetMatchesDifferences<kJetSize>(probeFunction(id, n, body), x, 1e-7, n);
}

// Noise stage: x = [accel B, gyro B, tau_s | averaging time]; the Gauss-Markov parameters of
// every axis and their Allan deviation at the averaging time.
void noiseProbe(EffectId id) {
  const auto [x, n] = probePoint(id, {30.0});
  const auto body = []<typename T>(const std::vector<T>& block, const T* tau) {
    std::vector<T> out;
    for (int k = 0; k < 6; ++k) {
      T sigma, t_c;
      effects::BiasInstability::gaussMarkov(block.data(), block[static_cast<std::size_t>(k)],
                                            &sigma, &t_c);
      out.insert(out.end(),
                 {sigma, t_c, effects::BiasInstability::allanDeviation(sigma, t_c, tau[0])});
    }
    return out;
  };
  expectJetMatchesDifferences<kJetSize>(probeFunction(id, n, body), x, 1e-7, n);
}

class EffectDerivatives : public ::testing::TestWithParam<EffectId> {};

TEST_P(EffectDerivatives, JetsMatchCentralDifferences) {
  const EffectId id = GetParam();
  ASSERT_TRUE(sampleParams().count(id)) << "no sample parameters for " << effectName(id);
  ASSERT_EQ(static_cast<int>(sampleParams().at(id).size()), flatSize(id));
  switch (effectStage(id)) {
    case Stage::kBodyInput:
    case Stage::kCoefficients:
    case Stage::kAxisInput:
    case Stage::kAxisNonlinear:
    case Stage::kReading:
      readingProbe(id);
      return;
    case Stage::kTime:
      timeProbe(id);
      return;
    case Stage::kSite:
      siteProbe(id);
      return;
    case Stage::kTable:
      tableProbe(id);
      return;
    case Stage::kAngle:
      angleProbe(id);
      return;
    case Stage::kNoise:
      noiseProbe(id);
      return;
  }
  FAIL() << "effect " << effectName(id) << " has no derivative probe";
}

INSTANTIATE_TEST_SUITE_P(EveryEffect, EffectDerivatives, ::testing::ValuesIn(kAllEffects),
                         [](const ::testing::TestParamInfo<EffectId>& param_info) {
                           return std::string(effectName(param_info.param));
                         });

TEST(EffectUnits, BiasInstabilityAllanPeakIsTheGivenMinimumAtTau) {
  const double block[] = {0, 0, 0, 0, 0, 0, 40.0};
  double sigma = 0.0, t_c = 0.0;
  effects::BiasInstability::gaussMarkov(block, 1e-5, &sigma, &t_c);
  const auto adev = [&](double tau) {
    return effects::BiasInstability::allanDeviation(sigma, t_c, tau);
  };
  EXPECT_NEAR(adev(40.0), 1e-5, 1e-15);
  // A maximum: lower on both sides.
  EXPECT_LT(adev(40.0 * 0.9), 1e-5);
  EXPECT_LT(adev(40.0 * 1.1), 1e-5);
}

TEST(EffectUnits, AngleHarmonicIsItsFormula) {
  const double p[] = {kTableAxisOuter, 3.0, 2e-4, -5e-4};
  const JointState<double> enc{0.8, 0.5, -0.2};
  const JointState<double> j = effects::AngleHarmonic::jointState(p, enc);
  const auto e = [&](double a) { return 2e-4 * std::cos(3 * a) - 5e-4 * std::sin(3 * a); };
  EXPECT_NEAR(j.angle, 0.8 + e(0.8), 1e-16);
  // rate = d/dt (a + e(a)) by a central difference along a(t) = 0.8 + 0.5 t - 0.1 t^2.
  const auto angleAt = [&](double t) {
    const double a = 0.8 + 0.5 * t - 0.1 * t * t;
    return a + e(a);
  };
  const double h = 1e-4;
  EXPECT_NEAR(j.rate, (angleAt(h) - angleAt(-h)) / (2 * h), 1e-9);
  EXPECT_NEAR(j.accel, (angleAt(h) - 2 * angleAt(0) + angleAt(-h)) / (h * h), 1e-6);
}

}  // namespace
}  // namespace imubench::calib::model
