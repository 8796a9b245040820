// Shared helpers for reading TOML documents (plan files, device files) with diagnostics that
// name file:line:column and the reason. Library code never prints or exits: errors are
// collected in a Diagnostics value the caller reports.
#pragma once

#include <toml++/toml.h>

#include <cstdint>
#include <initializer_list>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace imubench::io {

struct Diagnostic {
  std::string file;
  int line = 0;    // 1-based; 0 when unknown
  int column = 0;  // 1-based; 0 when unknown
  std::string message;
  // "file:line:column: message" (line/column left out when unknown).
  std::string str() const;
};

class Diagnostics {
 public:
  explicit Diagnostics(std::string file) : file_(std::move(file)) {}
  void error(const toml::source_region& where, std::string message);
  void error(int line, int column, std::string message);
  bool ok() const { return items_.empty(); }
  const std::vector<Diagnostic>& items() const { return items_; }
  const std::string& file() const { return file_; }
  // All diagnostics, one per line.
  std::string str() const;

 private:
  std::string file_;
  std::vector<Diagnostic> items_;
};

// The whole text of the file at `path`; when it cannot be opened, the diagnostic
// "cannot open <what> file" (what: "device", "bench", "DBC", ...) and nullopt.
std::optional<std::string> readTextFile(const std::string& path, std::string_view what,
                                        Diagnostics& diag);

// Parses TOML text; a syntax error becomes a diagnostic and nullopt is returned.
std::optional<toml::table> parseToml(std::string_view text, Diagnostics& diag);

// A physical quantity written with its unit, e.g. "180 deg", "10 deg/s", "15 min", "25 degC".
// Plan and device files require units on every dimensioned value: a bare number is refused.
enum class Dimension {
  kAngle,
  kRate,
  kAngularAccel,
  kTime,
  kTemperature,
  kTemperatureRate,
  kLength
};

// Converts "<number> <unit>" to SI (rad, rad/s, rad/s^2, s, degC, degC/s, m). Returns nullopt
// and sets *why on a missing or wrong unit. Accepted units:
//   angle: deg, rad, arcsec; rate: deg/s, rad/s, deg/h; angular accel: deg/s^2, rad/s^2;
//   time: s, ms, min, h; temperature: degC; temperature rate: degC/min, degC/s;
//   length: m, mm.
std::optional<double> parseQuantity(std::string_view text, Dimension dim, std::string* why);

// Reads a required quantity field of a table; reports a diagnostic at the node (or at the
// table when the key is missing) and returns nullopt on error.
std::optional<double> quantityField(const toml::table& t, std::string_view key, Dimension dim,
                                    Diagnostics& diag, bool required = true);

// Field readers shared by the TOML readers (device files, bench files). Each reports a
// diagnostic at the offending node, or at the table when a required key is missing.

// Refuses keys the schema does not know: a typo must not silently fall back to a default.
void checkKeys(const toml::table& t, std::initializer_list<std::string_view> allowed,
               std::string_view where, Diagnostics& diag);
const toml::table* subTable(const toml::table& t, std::string_view key, Diagnostics& diag,
                            bool required);
std::optional<std::string> strField(const toml::table& t, std::string_view key, Diagnostics& diag,
                                    bool required);
// An integer in [lo, hi].
std::optional<int64_t> intField(const toml::table& t, std::string_view key, Diagnostics& diag,
                                bool required, int64_t lo, int64_t hi);
std::optional<bool> boolField(const toml::table& t, std::string_view key, Diagnostics& diag);

}  // namespace imubench::io
