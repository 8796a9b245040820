#include "drivers/imu_can_reader.h"

namespace imubench::drivers {

bool ImuCanReaderOptions::IsValid(std::string* why) const {
  if (interface.empty()) {
    if (why) *why = "interface name is empty";
    return false;
  }
  if (batch == 0) {
    if (why) *why = "batch must be >= 1";
    return false;
  }
  return decoder.IsValid(why) && socket.IsValid(why);
}

ImuCanReader::ImuCanReader(ImuLayout layout, ImuCanReaderOptions options)
    : decoder_(std::move(layout), options.decoder), options_(std::move(options)) {
  buffer_.resize(options_.batch);
}

Status ImuCanReader::open() {
  std::string why;
  if (!options_.IsValid(&why)) return Status::Error("IMU reader options: " + why);
  CanSocketOptions so = options_.socket;
  bool needs_fd = false;
  for (const auto& m : decoder_.layout().messages) needs_fd = needs_fd || m.fd;
  so.fd = so.fd || needs_fd;
  return socket_.open(options_.interface, so);
}

Status ImuCanReader::poll(int timeout_ms, std::vector<DecodedImuSample>* out) {
  std::size_t n = 0;
  Status st = socket_.receive(buffer_, &n, timeout_ms);
  if (!st.ok) return st;
  decoder_.feed(std::span<const CanFrame>(buffer_.data(), n), out);
  return Status::Ok();
}

}  // namespace imubench::drivers
