// Scalar (field) calibration without a table: accelerometer from |f| = g in every static
// pose, gyro from the gravity-direction change between consecutive static poses
// (Tedaldi, Pretto, Menegatti 2014 / imu_tk method), mapped onto OUR eq.(1) parameters:
//     reading = diag(scale) * (M * input - bias),
//     M = [[1, m_xy, -m_xz], [-m_yx, 1, m_yz], [m_zx, -m_zy, 1]].
// Accelerometer: |f| = g cannot see a rotation of the whole triad, so the instrument frame is
// fixed to the accelerometer triad (z along accel z, y in the accel yz plane): m_yx = m_zx =
// m_zy = 0, reported "observable": false. Gyro: all six misalignments are relative to that
// frame. Gyro bias comes from the first static interval, less the vertical Earth rate when the
// latitude is known; its sigma includes the Earth rate it cannot separate and the bias drift
// between poses. During each rotation the bias is interpolated between the poses around it.
// With too few distinct poses the misalignments are fixed and flagged rather than fitted.
#pragma once

#include <array>
#include <optional>
#include <string>
#include <vector>

#include "calib/bench_truth.h"
#include "calib/static_detection.h"
#include "nav/rotation.h"

namespace imubench::calib {

// Flat names of the coefficients fitted here (bench_truth.h naming), in parameter-block order.
inline constexpr std::array<const char*, 3> kAxisNames = {"x", "y", "z"};

struct ScalarCalibrationOptions {
  // Local gravity magnitude, m/s^2 (9.81, or nav::normalGravity at the site's latitude).
  double gravity_mps2 = 9.81;
  // Gyro readings per rad/s, initial guess. Unset: a coarse 1-D search over decades finds
  // it from the data (raw counts have no known unit).
  std::optional<double> gyro_scale_guess;
  // Shortest acceptable first static interval, s: the gyro bias is its mean (imu_tk uses 50 s
  // for its own recording; hand sessions have a few seconds).
  double min_initial_static_s = 2.0;
  // Static poses required to fit the full accelerometer model (9 unknowns; imu_tk
  // recommends >= 36 poses). Fewer: misalignments fixed at 0 and flagged unobservable.
  // (counted as distinct gravity directions: poses closer than same_pose_angle_deg are one).
  int min_poses_full_accel = 12;
  // Two static poses whose gravity directions differ by less than this are the same face
  // (hand placement repeats a face within a few degrees; distinct faces differ by >= 30).
  double same_pose_angle_deg = 10.0;
  int min_poses_diagonal_accel = 6;
  // Physical-unit accelerometer data (accel_unit_is_si): every static pose's |f| must be
  // within this fraction of gravity. Sensor errors are percent-level at worst; a pose far off
  // means swapped columns, a wrong unit or motion taken for rest.
  double si_gravity_tolerance = 0.1;
  // Largest acceptable per-sample scatter of the static readings in the calibrated unit, as a
  // fraction of g. A real accelerometer's white noise is far below 1 % of g; a scatter this
  // large means the poses did not change the gravity direction (one orientation, or the
  // columns are not the accelerometer's) and the scales would be fitted to noise.
  double max_static_scatter_g = 0.05;
  // Each calibrated axis must see gravity components spanning at least this range (of the
  // unit sphere, -1..1): scale and bias of an axis are separable only when it is tilted well
  // both ways (a six-face session spans 2).
  double min_axis_span = 1.0;
  // Largest acceptable RMS mismatch, rad, between the integrated gyro rotation and the
  // gravity-direction change of each rotation: far above the noise (mrad) means the gyro is not
  // the accelerometer's companion in the same frame (swapped or mirrored axes).
  double max_gyro_rms_rad = 0.05;
  // Site latitude, rad, when known: the vertical Earth rate in the first pose is removed from
  // the gyro bias, and only the horizontal part (unknown heading) widens its sigma. Unset: all
  // of the Earth rate widens the bias sigma.
  std::optional<double> latitude_rad;
  // Gyro bias during each rotation: the straight line between the rest readings of the poses
  // before and after (true, default: MEMS biases move by 0.1-1 mrad/s between poses), or the
  // first pose's rest reading throughout (false: imu_tk's assumption).
  bool interpolate_gyro_bias = true;
  // Plausible magnitude (1 sigma, rad) of the accelerometer misalignments xy, xz, yz when the
  // poses are too few to fit them (held at 0): a Schmidt consider term carries it into the
  // gyro scales' and misalignments' sigmas, Sigma += S P S^T with S the sensitivity of the
  // gyro fit to each held misalignment (the gravity directions it compares move with them).
  // 1 % (0.01 rad): consumer MEMS datasheets give cross-axis sensitivity of 1-2 %; lower it
  // for a better-graded IMU, 0 leaves the held misalignments out of the sigmas.
  double held_accel_misalignment_prior_rad = 0.01;
  // Readings of static samples are skipped this long at each span end, s (settling).
  double span_trim_s = 0.1;
  StaticDetectionOptions detection;
  RecordingCheckOptions checks;
  // The IMU's symmetric ranges (datasheet), SI: a sample whose calibrated rate or specific
  // force reaches them on any axis is clipped and the recording refused (kSaturated), whatever
  // the reading unit (checked after the fit, on the calibrated inputs). Unset: not checked.
  std::optional<double> gyro_range_radps;
  std::optional<double> accel_range_mps2;

  // Solver settings of the two least-squares fits (Ceres).
  struct Solver {
    int max_iterations = 100;
    double function_tolerance = 1e-12;
    double parameter_tolerance = 1e-8;
  };
  // |f| = g is mildly nonlinear from the min/max start and converges in a few iterations; the
  // cap of 200 only bounds a pathological recording. Tolerances of 1e-14: the cost is in
  // (m/s^2)^2 and raw-count scales are ~1e2-1e4, so the default 1e-6/1e-8 would stop far above
  // the parameters' sigmas.
  Solver accel_solver{200, 1e-14, 1e-14};
  // The gravity-direction fit re-integrates every rotation per evaluation: 100 iterations from
  // the decade search's start are ample; 1e-12 relative cost change is far below the noise.
  Solver gyro_solver{100, 1e-12, 1e-8};

  bool IsValid(std::string* why) const;
};

struct ScalarCalibrationResult {
  RecordingCheck status;  // refusals (bad data) and solver failures land here
  std::vector<StaticSpan> spans;
  // Coefficients in eq.(1) form: report.values.sensors.accel (scale in reading unit per
  // m/s^2, bias m/s^2) and .gyro (reading unit per rad/s, bias rad/s), with sigmas and
  // "observable": false flags by flat name; toJson(report) gives the interchange JSON.
  CoefficientReport report;
  const TriadModel& accel() const { return report.values.sensors.accel; }
  const TriadModel& gyro() const { return report.values.sensors.gyro; }
  // RMS over static spans of |f| - g, m/s^2: "before" uses the initial (per-axis min/max)
  // estimate for raw units, or the readings themselves when accel_unit_is_si was set.
  double accel_rms_before = 0.0;
  double accel_rms_after = 0.0;
  // RMS of the gravity-direction mismatch between consecutive poses (rad-like, unit vectors).
  double gyro_rms_before = 0.0;
  double gyro_rms_after = 0.0;
  int rotations_used = 0;
  // Earth rate invariant: static gyro mean-rate scatter (rad/s) compared with 7.29e-5 rad/s.
  double static_rate_scatter = 0.0;
  bool earth_rate_usable = false;
  std::vector<std::string> notes;  // plain-language statements (what is fixed and why)
};

// accel_unit_is_si: the accelerometer readings are already m/s^2 (then "before" is the raw
// data). Runs checks, detection, accel fit, gyro fit.
ScalarCalibrationResult scalarCalibrate(const RawImuData& data,
                                        const ScalarCalibrationOptions& options = {},
                                        bool accel_unit_is_si = false);

// Plain-text summary for people: poses found, RMS of |a| - g before/after, the gravity-
// direction mismatch, the coefficients of both triads in reading units with sigmas (or
// "unobservable, fixed"), and the notes. One line per item, each ending in '\n'.
std::string describe(const ScalarCalibrationResult& r);

}  // namespace imubench::calib
