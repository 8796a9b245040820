# Calibration engine sources (direct, indirect, scalar, observability): target_sources(imubench_calib PRIVATE ...)
