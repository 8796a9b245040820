# Forward model and simulator sources: target_sources(imubench_calib PRIVATE ...)
