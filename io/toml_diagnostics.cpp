#include "io/toml_diagnostics.h"

#include <charconv>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <utility>

#include "nav/rotation.h"

namespace imubench::io {

std::string Diagnostic::str() const {
  std::string s = file;
  if (line > 0) {
    s += ":" + std::to_string(line);
    if (column > 0) s += ":" + std::to_string(column);
  }
  return s + ": " + message;
}

void Diagnostics::error(const toml::source_region& where, std::string message) {
  items_.push_back({file_, static_cast<int>(where.begin.line), static_cast<int>(where.begin.column),
                    std::move(message)});
}

void Diagnostics::error(int line, int column, std::string message) {
  items_.push_back({file_, line, column, std::move(message)});
}

std::string Diagnostics::str() const {
  std::string s;
  for (const auto& d : items_) s += d.str() + "\n";
  return s;
}

std::optional<std::string> readTextFile(const std::string& path, std::string_view what,
                                        Diagnostics& diag) {
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    diag.error(0, 0, "cannot open " + std::string(what) + " file");
    return std::nullopt;
  }
  std::ostringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

std::optional<toml::table> parseToml(std::string_view text, Diagnostics& diag) {
  // toml++ is built with exceptions here (Debian's default): a syntax error throws.
  try {
    return toml::parse(text, diag.file());
  } catch (const toml::parse_error& err) {
    diag.error(err.source(), std::string(err.description()));
    return std::nullopt;
  }
}

namespace {

struct UnitDef {
  std::string_view name;
  Dimension dim;
  double to_si;
};

constexpr UnitDef kUnits[] = {
    {"deg", Dimension::kAngle, kDegToRad},
    {"rad", Dimension::kAngle, 1.0},
    {"arcsec", Dimension::kAngle, kArcsecToRad},
    {"deg/s", Dimension::kRate, kDegToRad},
    {"rad/s", Dimension::kRate, 1.0},
    {"deg/h", Dimension::kRate, kDegToRad / 3600.0},
    {"deg/s^2", Dimension::kAngularAccel, kDegToRad},
    {"rad/s^2", Dimension::kAngularAccel, 1.0},
    {"s", Dimension::kTime, 1.0},
    {"ms", Dimension::kTime, 1e-3},
    {"min", Dimension::kTime, 60.0},
    {"h", Dimension::kTime, 3600.0},
    {"degC", Dimension::kTemperature, 1.0},
    {"degC/min", Dimension::kTemperatureRate, 1.0 / 60.0},
    {"degC/s", Dimension::kTemperatureRate, 1.0},
    {"m", Dimension::kLength, 1.0},
    {"mm", Dimension::kLength, 1e-3},
};

const char* dimensionName(Dimension d) {
  switch (d) {
    case Dimension::kAngle:
      return "an angle (deg, rad, arcsec)";
    case Dimension::kRate:
      return "a rate (deg/s, rad/s, deg/h)";
    case Dimension::kAngularAccel:
      return "an angular acceleration (deg/s^2, rad/s^2)";
    case Dimension::kTime:
      return "a duration (s, ms, min, h)";
    case Dimension::kTemperature:
      return "a temperature (degC)";
    case Dimension::kTemperatureRate:
      return "a temperature rate (degC/min, degC/s)";
    case Dimension::kLength:
      return "a length (m, mm)";
  }
  return "a quantity";
}

std::string_view exampleUnit(Dimension d) {
  for (const auto& u : kUnits) {
    if (u.dim == d) return u.name;
  }
  return "";
}

}  // namespace

std::optional<double> parseQuantity(std::string_view text, Dimension dim, std::string* why) {
  auto fail = [&](std::string msg) -> std::optional<double> {
    if (why) *why = std::move(msg);
    return std::nullopt;
  };
  while (!text.empty() && text.front() == ' ') text.remove_prefix(1);
  while (!text.empty() && text.back() == ' ') text.remove_suffix(1);
  double value = 0.0;
  const char* first = text.data();
  const char* last = text.data() + text.size();
  if (!text.empty() && *first == '+') ++first;
  auto [ptr, ec] = std::from_chars(first, last, value);
  if (ec != std::errc() || !std::isfinite(value)) {
    return fail("expected " + std::string(dimensionName(dim)) + " like \"10 deg\", got \"" +
                std::string(text) + "\"");
  }
  std::string_view unit(ptr, static_cast<size_t>(last - ptr));
  while (!unit.empty() && unit.front() == ' ') unit.remove_prefix(1);
  if (unit.empty()) {
    return fail("missing unit: \"" + std::string(text) + "\" must be " + dimensionName(dim));
  }
  for (const auto& u : kUnits) {
    if (u.name == unit) {
      if (u.dim != dim) {
        return fail("wrong unit \"" + std::string(unit) + "\": expected " + dimensionName(dim));
      }
      return value * u.to_si;
    }
  }
  return fail("unknown unit \"" + std::string(unit) + "\": expected " + dimensionName(dim));
}

std::optional<double> quantityField(const toml::table& t, std::string_view key, Dimension dim,
                                    Diagnostics& diag, bool required) {
  const toml::node* node = t.get(key);
  if (!node) {
    if (required) {
      diag.error(t.source(),
                 "missing required key \"" + std::string(key) + "\" (" + dimensionName(dim) + ")");
    }
    return std::nullopt;
  }
  if (node->is_integer() || node->is_floating_point()) {
    char number[32];
    std::snprintf(number, sizeof number, "%g", node->value_or(0.0));
    diag.error(node->source(), "missing unit on \"" + std::string(key) +
                                   "\": write the value as a string with its unit, e.g. " +
                                   std::string(key) + " = \"" + number + " " +
                                   std::string(exampleUnit(dim)) + "\" (" + dimensionName(dim) +
                                   ")");
    return std::nullopt;
  }
  const auto* s = node->as_string();
  if (!s) {
    diag.error(node->source(), "\"" + std::string(key) + "\" must be a string like \"10 deg\"");
    return std::nullopt;
  }
  std::string why;
  auto v = parseQuantity(s->get(), dim, &why);
  if (!v) diag.error(node->source(), "\"" + std::string(key) + "\": " + why);
  return v;
}

// Refuses keys the schema does not know: a typo must not silently fall back to a default.
void checkKeys(const toml::table& t, std::initializer_list<std::string_view> allowed,
               std::string_view where, Diagnostics& diag) {
  for (const auto& [k, v] : t) {
    bool known = false;
    for (auto a : allowed) known = known || (a == k.str());
    if (!known) {
      diag.error(k.source(),
                 "unknown key \"" + std::string(k.str()) + "\" in " + std::string(where));
    }
  }
}

namespace {

// The node at `key` when it is there and of the type `want`; nullptr otherwise, with a
// diagnostic at the table when a required key is missing, at the node when it is "\"key\"
// must be <must_be>".
const toml::node* typedField(const toml::table& t, std::string_view key, toml::node_type want,
                             std::string_view must_be, bool required, Diagnostics& diag) {
  const toml::node* n = t.get(key);
  if (!n) {
    if (required) {
      diag.error(t.source(), want == toml::node_type::table
                                 ? "missing required table [" + std::string(key) + "]"
                                 : "missing required key \"" + std::string(key) + "\"");
    }
    return nullptr;
  }
  if (n->type() != want) {
    diag.error(n->source(), "\"" + std::string(key) + "\" must be " + std::string(must_be));
    return nullptr;
  }
  return n;
}

}  // namespace

const toml::table* subTable(const toml::table& t, std::string_view key, Diagnostics& diag,
                            bool required) {
  const toml::node* n = typedField(t, key, toml::node_type::table, "a table", required, diag);
  return n ? n->as_table() : nullptr;
}

std::optional<std::string> strField(const toml::table& t, std::string_view key, Diagnostics& diag,
                                    bool required) {
  const toml::node* n = typedField(t, key, toml::node_type::string, "a string", required, diag);
  if (!n) return std::nullopt;
  return n->as_string()->get();
}

std::optional<int64_t> intField(const toml::table& t, std::string_view key, Diagnostics& diag,
                                bool required, int64_t lo, int64_t hi) {
  const toml::node* n = typedField(t, key, toml::node_type::integer, "an integer", required, diag);
  if (!n) return std::nullopt;
  const int64_t v = n->as_integer()->get();
  if (v < lo || v > hi) {
    diag.error(n->source(), "\"" + std::string(key) + "\" = " + std::to_string(v) +
                                " is out of range [" + std::to_string(lo) + ", " +
                                std::to_string(hi) + "]");
    return std::nullopt;
  }
  return v;
}

std::optional<bool> boolField(const toml::table& t, std::string_view key, Diagnostics& diag) {
  const toml::node* n = typedField(t, key, toml::node_type::boolean, "true or false", false, diag);
  if (!n) return std::nullopt;
  return n->as_boolean()->get();
}

}  // namespace imubench::io
