#include "drivers/virtual_table_scpi.h"

#include <fcntl.h>
#include <poll.h>
#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>

namespace imubench::drivers {

namespace {

// A command template as a regex: {axis} -> an integer, {value} -> a number.
std::regex templateRegex(const std::string& tmpl) {
  static const std::string kSpecial = R"(\^$.|?*+()[]{})";
  std::string re;
  for (size_t i = 0; i < tmpl.size(); ++i) {
    if (tmpl.compare(i, 6, "{axis}") == 0) {
      re += R"(\s*(\d+)\s*)";
      i += 5;
    } else if (tmpl.compare(i, 7, "{value}") == 0) {
      re += R"(\s*([-+]?[0-9]*\.?[0-9]+(?:[eE][-+]?[0-9]+)?)\s*)";
      i += 6;
    } else {
      if (kSpecial.find(tmpl[i]) != std::string::npos) re += '\\';
      re += tmpl[i];
    }
  }
  return std::regex(re, std::regex::icase);
}

std::string number(double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.6f", v);
  return buf;
}

}  // namespace

VirtualTableScpi::VirtualTableScpi(VirtualWorld& world, const TableDeviceSpec& spec,
                                   LinkFaults& faults, EventSink sink)
    : world_(world), spec_(spec), faults_(faults), sink_(std::move(sink)) {
  const auto& c = spec_.commands;
  const std::pair<Op, const SerialCommand*> all[] = {
      {Op::kModeOff, &c.mode_off},
      {Op::kModePos, &c.mode_position},
      {Op::kModeRate, &c.mode_rate},
      {Op::kDemandPos, &c.demand_position},
      {Op::kDemandRate, &c.demand_rate},
      {Op::kRotate, &c.rotate},
      {Op::kStop, &c.stop},
      {Op::kEstop, &c.estop},
      {Op::kReadPos, &c.read_position},
      {Op::kReadRate, &c.read_rate},
      {Op::kReadStatus, &c.read_status},
      {Op::kReadAxisStatus, &c.read_axis_status},
      {Op::kIlClose, &c.interlock_close},
      {Op::kIlOpen, &c.interlock_open},
      {Op::kIlReset, &c.interlock_reset},
      {Op::kSetRateLimit, &c.set_rate_limit},
      {Op::kSetAccelLimit, &c.set_accel_limit},
  };
  for (const auto& [op, cmd] : all) {
    if (cmd->text.empty()) continue;  // an optional command the device file does not give
    patterns_.push_back({op, templateRegex(cmd->text),
                         cmd->text.find("{axis}") != std::string::npos,
                         cmd->text.find("{value}") != std::string::npos});
  }
}

VirtualTableScpi::~VirtualTableScpi() {
  stop();
}

Status VirtualTableScpi::start() {
  if (pipe2(wake_, O_CLOEXEC | O_NONBLOCK) != 0) {
    return Status::Error(std::string("pipe: ") + std::strerror(errno));
  }
  if (Status s = pty_.open(); !s.ok) return s;
  thread_ = std::thread([this] { run(); });
  return Status::Ok();
}

void VirtualTableScpi::stop() {
  if (thread_.joinable()) {
    stopping_ = true;
    const char b = 's';
    [[maybe_unused]] auto n = ::write(wake_[1], &b, 1);
    thread_.join();
  }
  for (int& fd : wake_) {
    if (fd >= 0) ::close(fd);
    fd = -1;
  }
  pty_.close();
}

// One recognised command on the table at time t; *reply is the ack unless a query fills it.
bool VirtualTableScpi::execute(Op op, VirtualTable& table, double t, int axis, double value,
                               std::string* reply, std::string* why) {
  const auto& c = spec_.commands;
  switch (op) {
    case Op::kModeOff:
      return table.setMode(t, axis, AxisMode::kOff, why);
    case Op::kModePos:
      return table.setMode(t, axis, AxisMode::kPosition, why);
    case Op::kModeRate:
      return table.setMode(t, axis, AxisMode::kRate, why);
    case Op::kDemandPos:
      return table.moveTo(t, axis, value * c.angle_unit, why);
    case Op::kDemandRate:
      return table.setRate(t, axis, value * c.rate_unit, why);
    case Op::kRotate:
      return table.rotateBy(t, axis, value * c.angle_unit, why);
    case Op::kStop:
      table.stop(t, axis);
      break;
    case Op::kEstop:
      table.emergencyStop(t);
      break;
    case Op::kReadPos:
      *reply = number(table.axis(t, axis).reported_angle / c.angle_unit);
      break;
    case Op::kReadRate:
      *reply = number(table.axis(t, axis).rate / c.rate_unit);
      break;
    case Op::kReadStatus:
      *reply = std::to_string(table.statusWord(t));
      break;
    case Op::kReadAxisStatus:
      *reply = std::to_string(table.axisStatusWord(t, axis));
      break;
    case Op::kIlClose:
      table.interlockClose(t, why);
      return why->empty();
    case Op::kIlOpen:
      table.interlockOpen(t);
      break;
    case Op::kIlReset:
      table.interlockReset(t);
      break;
    case Op::kSetRateLimit:
      return table.setRateLimit(axis, value * c.rate_unit, why);
    case Op::kSetAccelLimit:
      return table.setAccelLimit(axis, value * c.accel_unit, why);
  }
  return true;
}

std::string VirtualTableScpi::handle(const std::string& line) {
  const auto& c = spec_.commands;
  const std::string err = c.error_prefix.empty() ? "ERR" : c.error_prefix;
  for (const auto& p : patterns_) {
    std::smatch m;
    if (!std::regex_match(line, m, p.re)) continue;
    int axis = -1;
    double value = 0.0;
    size_t g = 1;
    if (p.axis) {
      axis = std::stoi(m[g++].str()) - c.axis_base;
      if (axis < 0 || axis >= spec_.axisCount()) return err + " no such axis";
    }
    if (p.value) value = std::stod(m[g].str());
    std::string why;
    bool ok = true;
    std::string reply = c.ack;
    world_.withTable([&](VirtualTable& table, double t) {
      ok = execute(p.op, table, t, axis, value, &reply, &why);
      return 0;
    });
    if (!ok) {
      if (sink_) sink_("virtual table (serial): \"" + line + "\" refused: " + why);
      return err + " " + why;
    }
    return reply;
  }
  if (sink_) sink_("virtual table (serial): unknown command \"" + line + "\"");
  return err + " unknown command";
}

void VirtualTableScpi::run() {
  const int fd = pty_.masterFd();
  const std::string& term = spec_.transport.terminator;
  std::string buffer;
  while (!stopping_) {
    pollfd p[2] = {{fd, POLLIN, 0}, {wake_[0], POLLIN, 0}};
    if (::poll(p, 2, -1) < 0) {
      if (errno == EINTR) continue;
      break;
    }
    if (stopping_ || (p[1].revents & POLLIN)) break;
    if (!(p[0].revents & POLLIN)) continue;
    char buf[256];
    const ssize_t n = ::read(fd, buf, sizeof buf);
    if (n <= 0) continue;
    buffer.append(buf, static_cast<size_t>(n));
    if (buffer.size() > 4096) buffer.clear();  // garbage without terminators
    for (auto pos = buffer.find(term); pos != std::string::npos; pos = buffer.find(term)) {
      std::string line = buffer.substr(0, pos);
      buffer.erase(0, pos + term.size());
      // A CR/LF mismatch with the client shows as a stray CR or LF at either end.
      while (!line.empty() && (line.back() == '\r' || line.back() == '\n')) line.pop_back();
      while (!line.empty() && (line.front() == '\r' || line.front() == '\n')) line.erase(0, 1);
      if (line.empty()) continue;
      if (faults_.drop_replies) {
        if (sink_) sink_("virtual table (serial): fault injection: no reply to \"" + line + "\"");
        continue;
      }
      const std::string reply = handle(line);
      const double delay = faults_.reply_delay_s;
      if (delay > 0) {
        if (sink_) sink_("virtual table (serial): fault injection: reply delayed");
        pollfd w{wake_[0], POLLIN, 0};
        if (::poll(&w, 1, static_cast<int>(delay * 1000)) > 0) return;
      }
      if (reply.empty()) continue;
      const std::string out = reply + term;
      size_t done = 0;
      while (done < out.size()) {
        const ssize_t w = ::write(fd, out.data() + done, out.size() - done);
        if (w <= 0) break;
        done += static_cast<size_t>(w);
      }
    }
  }
}

}  // namespace imubench::drivers
