# IMU over SocketCAN: layouts, DBC, reader, virtual IMU sender: target_sources(imubench_drivers PRIVATE ...)
target_sources(imubench_drivers PRIVATE
  can_signal.cpp
  can_socket.cpp
  dbc_parser.cpp
  imu_layout.cpp
  imu_decoder.cpp
  imu_encoder.cpp
  imu_can_reader.cpp
  virtual_imu_can.cpp
)
# Shipped IMU device files and DBCs (read at run time; tests use this path).
set(IMUBENCH_IMU_DEVICE_DIR ${CMAKE_CURRENT_SOURCE_DIR}/devices/imus CACHE INTERNAL "IMU device files")
