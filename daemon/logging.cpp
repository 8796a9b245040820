#include "daemon/logging.h"

#include <syslog.h>

#include <cstdio>
#include <string>

namespace imubench::daemon {

namespace {
int syslogPriority(LogLevel level) {
  switch (level) {
    case LogLevel::kDebug:
      return LOG_DEBUG;
    case LogLevel::kInfo:
      return LOG_INFO;
    case LogLevel::kNotice:
      return LOG_NOTICE;
    case LogLevel::kWarning:
      return LOG_WARNING;
    case LogLevel::kError:
      return LOG_ERR;
  }
  return LOG_INFO;
}
const char* levelName(LogLevel level) {
  switch (level) {
    case LogLevel::kDebug:
      return "debug";
    case LogLevel::kInfo:
      return "info";
    case LogLevel::kNotice:
      return "notice";
    case LogLevel::kWarning:
      return "warning";
    case LogLevel::kError:
      return "error";
  }
  return "info";
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
