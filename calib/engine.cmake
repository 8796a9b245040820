# Calibration engine sources (direct, indirect, scalar, observability): target_sources(imubench_calib PRIVATE ...)
# Navigation-based (indirect) calibration, validation experiment, shared result type.
target_sources(imubench_calib PRIVATE
  calibration_result.cpp
  indirect_calibration.cpp
  indirect_preintegration.cpp
)
