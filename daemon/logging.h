// Logging through syslog(3) (journald picks it up under systemd). A Logger value is passed to
// whoever needs it: no global logger object. Library code outside daemon/ does not log; it
// returns statuses, and daemon/ decides what to log.
#pragma once

#include <string>
#include <string_view>

namespace imubench::daemon {

enum class LogLevel { kDebug, kInfo, kNotice, kWarning, kError };

class Logger {
 public:
  // ident: syslog identity ("imubenchd"); also_stderr: mirror to stderr (foreground runs, CLI).
  Logger(std::string ident, bool also_stderr);
  ~Logger();
  Logger(const Logger&) = delete;
  Logger& operator=(const Logger&) = delete;

  void log(LogLevel level, std::string_view message) const;
  void info(std::string_view m) const { log(LogLevel::kInfo, m); }
  void warning(std::string_view m) const { log(LogLevel::kWarning, m); }
  void error(std::string_view m) const { log(LogLevel::kError, m); }

 private:
  std::string ident_;
  bool also_stderr_;
};

}  // namespace imubench::daemon
