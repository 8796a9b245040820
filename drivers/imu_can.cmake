# IMU over SocketCAN: layouts, DBC, reader, virtual IMU sender: target_sources(imubench_drivers PRIVATE ...)
