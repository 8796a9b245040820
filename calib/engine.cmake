# Calibration engine sources (direct, indirect, scalar, observability): target_sources(imubench_calib PRIVATE ...)
# Direct calibration, scalar (field) calibration, static detection, observability.
target_sources(imubench_calib PRIVATE
  static_detection.cpp
  scalar_calibration.cpp
  scalar_consistency.cpp
  observability.cpp
  direct_calibration.cpp
  segment_check.cpp
  fit_quality.cpp
  calibration_service.cpp
  thermal_service.cpp
  recording_checks.cpp
  thermal_fit.cpp
  thermal_fit_joint.cpp
)
# Navigation-based (indirect) calibration, validation experiment, shared result type.
target_sources(imubench_calib PRIVATE
  bench_calibration.cpp
  truth_comparison.cpp
  calibration_result.cpp
  indirect_calibration.cpp
  indirect_preintegration.cpp
  validation_experiment.cpp
)
