// imubench-e2e-soak-prediction PLAN CHAMBER_DEVICE IMU_TAU_S: the plan expander's planned soak
// durations (calib/model/thermal_lag.h settlingTime) with the same thermal parameters the
// virtual bench runs (the chamber device file's time_constant, the IMU's --imu-thermal-tau),
// one line per chamber soak: "LABEL PLANNED_S MAX_SOAK_S". The soak e2e (soak_detection.sh)
// compares the daemon's measured soak with it, so the model is never restated in the test.
// Exit 1 with the file's diagnostics on a refused plan or device file.
#include <cstdio>
#include <exception>
#include <stdexcept>
#include <string>

#include "drivers/device_file.h"
#include "plans/expand.h"
#include "plans/plan.h"
#include "plans/validator.h"

namespace {

int run(const std::string& plan_path, const std::string& chamber_path, double imu_tau_s) {
  using namespace imubench;
  io::Diagnostics cdiag(chamber_path);
  const auto chamber = drivers::loadChamberDevice(chamber_path, cdiag);
  if (!chamber) {
    std::fprintf(stderr, "%s\n", cdiag.str().c_str());
    return 1;
  }
  io::Diagnostics pdiag(plan_path);
  const auto plan = plans::loadPlanFile(plan_path, pdiag);
  if (!plan || !plans::validatePlan(*plan, pdiag)) {
    std::fprintf(stderr, "%s\n", pdiag.str().c_str());
    return 1;
  }
  plans::ExpandOptions options;
  options.thermal = {chamber->time_constant_s, imu_tau_s};
  const plans::ExpandResult ex = plans::expand(*plan, options);
  if (!ex.status.ok) {
    std::fprintf(stderr, "%s: %s\n", plan_path.c_str(), ex.status.message.c_str());
    return 1;
  }
  for (const calib::Segment& s : ex.motion.segments) {
    if (s.kind != calib::SegmentKind::kSoak) continue;
    std::printf("%s %.6f %.6f\n", s.label.c_str(), s.t1 - s.t0, s.max_soak_s);
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 4) {
    std::fprintf(stderr, "usage: %s PLAN CHAMBER_DEVICE IMU_TAU_S\n", argv[0]);
    return 2;
  }
  double tau = 0.0;
  try {
    std::size_t used = 0;
    tau = std::stod(argv[3], &used);
    if (used != std::string(argv[3]).size() || !(tau >= 0.0)) throw std::invalid_argument("");
  } catch (const std::exception&) {
    std::fprintf(stderr, "IMU_TAU_S: a non-negative number of seconds, not '%s'\n", argv[3]);
    return 2;
  }
  return run(argv[1], argv[2], tau);
}
