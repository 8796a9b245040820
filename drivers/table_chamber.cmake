# Turntable and chamber drivers (Modbus TCP/RTU, serial) and their virtual servers.
target_sources(imubench_drivers PRIVATE
  device_file.cpp
  modbus_codec.cpp
  modbus_link.cpp
  modbus_server.cpp
  modbus_device_models.cpp
  serial_port.cpp
  serial_pty.cpp
  table.cpp
  table_factory.cpp
  table_modbus.cpp
  table_serial.cpp
  chamber_modbus.cpp
  virtual_table.cpp
  virtual_table_scpi.cpp
  virtual_chamber.cpp
)
