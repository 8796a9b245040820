#include "daemon/logging.h"

#include <syslog.h>

#include <cstdio>
#include <string>

#include "io/enum_names.h"

namespace imubench::daemon {

namespace {
struct LevelRow {
  LogLevel value;
  const char* name;
  int priority;  // syslog's
};

constexpr LevelRow kLevels[] = {
    {LogLevel::kDebug, "debug", LOG_DEBUG},    {LogLevel::kInfo, "info", LOG_INFO},
    {LogLevel::kNotice, "notice", LOG_NOTICE}, {LogLevel::kWarning, "warning", LOG_WARNING},
    {LogLevel::kError, "error", LOG_ERR},
};

int syslogPriority(LogLevel level) {
  for (const auto& row : kLevels)
    if (row.value == level) return row.priority;
  return LOG_INFO;
}

const char* levelName(LogLevel level) {
  return io::nameOf(kLevels, level, "info");
}
}  // namespace

Logger::Logger(std::string ident, bool also_stderr)
    : ident_(std::move(ident)), also_stderr_(also_stderr) {
  // openlog keeps the pointer: ident_ lives as long as this Logger.
  openlog(ident_.c_str(), LOG_PID | LOG_NDELAY, LOG_DAEMON);
}

Logger::~Logger() {
  closelog();
}

void Logger::log(LogLevel level, std::string_view message) const {
  const std::string m(message);
  syslog(syslogPriority(level), "%s", m.c_str());
  if (also_stderr_)
    std::fprintf(stderr, "%s: %s: %s\n", ident_.c_str(), levelName(level), m.c_str());
}

}  // namespace imubench::daemon
