# Forward model and simulator sources: target_sources(imubench_calib PRIVATE ...)
target_sources(imubench_calib PRIVATE
  ${CMAKE_CURRENT_LIST_DIR}/sensor_model.cpp
  ${CMAKE_CURRENT_LIST_DIR}/table_model.cpp
  ${CMAKE_CURRENT_LIST_DIR}/effects.cpp
  ${CMAKE_CURRENT_LIST_DIR}/bench_truth.cpp
  ${CMAKE_CURRENT_LIST_DIR}/noise.cpp
  ${CMAKE_CURRENT_LIST_DIR}/simulator.cpp
)
