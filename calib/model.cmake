# Forward model and simulator sources: target_sources(imubench_calib PRIVATE ...)
# calib/model/ holds the templated forward model itself (header-only: sensor equation, table
# chains, bench physics, effect units); the double-precision fronts (sensor_model, table_model, effects) and
# the simulator below call it. It stays in imubench_calib (one target for calib/) because the
# templates compile into their callers and the fronts keep their include paths for daemon/,
# drivers/ and plans/.
target_sources(imubench_calib PRIVATE
  ${CMAKE_CURRENT_LIST_DIR}/model/scalar.h
  ${CMAKE_CURRENT_LIST_DIR}/model/sensor_equation.h
  ${CMAKE_CURRENT_LIST_DIR}/model/table_chain.h
  ${CMAKE_CURRENT_LIST_DIR}/model/bench_physics.h
  ${CMAKE_CURRENT_LIST_DIR}/model/motion_profile.h
  ${CMAKE_CURRENT_LIST_DIR}/model/thermal_lag.h
  ${CMAKE_CURRENT_LIST_DIR}/model/thermal_coefficients.h
  ${CMAKE_CURRENT_LIST_DIR}/model/effect_unit.h
  ${CMAKE_CURRENT_LIST_DIR}/model/effects.h
  ${CMAKE_CURRENT_LIST_DIR}/model/effects/site.h
  ${CMAKE_CURRENT_LIST_DIR}/model/effects/table.h
  ${CMAKE_CURRENT_LIST_DIR}/model/effects/time.h
  ${CMAKE_CURRENT_LIST_DIR}/model/effects/reading.h
  ${CMAKE_CURRENT_LIST_DIR}/model/effects/thermal.h
  ${CMAKE_CURRENT_LIST_DIR}/model/effects/noise.h
  ${CMAKE_CURRENT_LIST_DIR}/sensor_model.cpp
  ${CMAKE_CURRENT_LIST_DIR}/table_model.cpp
  ${CMAKE_CURRENT_LIST_DIR}/effects.cpp
  ${CMAKE_CURRENT_LIST_DIR}/bench_truth.cpp
  ${CMAKE_CURRENT_LIST_DIR}/noise.cpp
  ${CMAKE_CURRENT_LIST_DIR}/thermal_model.cpp
  ${CMAKE_CURRENT_LIST_DIR}/simulator.cpp
)
