# Turntable and chamber drivers (Modbus TCP/RTU, serial) and their virtual servers: target_sources(imubench_drivers PRIVATE ...)
