# Model-discrepancy analysis (imubench explain, issue 14): noise floor, the recording's bins and
# the forward model's prediction of them, the gate / selection / refit, the interchange report.
target_sources(imubench_calib PRIVATE
  ${CMAKE_CURRENT_LIST_DIR}/explain_noise.cpp
  ${CMAKE_CURRENT_LIST_DIR}/explain_model.cpp
  ${CMAKE_CURRENT_LIST_DIR}/explain_fit.cpp
  ${CMAKE_CURRENT_LIST_DIR}/explain.cpp
  ${CMAKE_CURRENT_LIST_DIR}/explain_json.cpp
  ${CMAKE_CURRENT_LIST_DIR}/explain_baseline.cpp
  ${CMAKE_CURRENT_LIST_DIR}/explain_scalar.cpp
  ${CMAKE_CURRENT_LIST_DIR}/explain_propose.cpp
  ${CMAKE_CURRENT_LIST_DIR}/explain_joint.cpp
)
