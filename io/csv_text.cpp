#include "io/csv_text.h"

#include <system_error>

namespace imubench::io {

std::string quoteForMessage(std::string_view s) {
  constexpr size_t kMax = 40;
  std::string r = "'";
  r.append(s.substr(0, kMax));
  if (s.size() > kMax) r += "...";
  return r + "'";
}

std::string fmtDouble(double v) {
  char buf[64];
  const auto r = std::to_chars(buf, buf + sizeof(buf), v);
  return std::string(buf, r.ptr);
}

bool parseNumber(std::string_view field, std::string_view column, double* value, std::string* why) {
  if (field.empty()) {
    *why = "column '" + std::string(column) + "' is empty";
    return false;
  }
  const char* b = field.data();
  const char* e = field.data() + field.size();
  const auto r = std::from_chars(b, e, *value);
  if (r.ec == std::errc::result_out_of_range) {
    *why = "column '" + std::string(column) + "': number out of range " + quoteForMessage(field);
    return false;
  }
  if (r.ec != std::errc() || r.ptr != e) {
    *why = "column '" + std::string(column) + "': not a number " + quoteForMessage(field);
    return false;
  }
  if (!std::isfinite(*value)) {
    *why = "column '" + std::string(column) + "': non-finite value " + quoteForMessage(field);
    return false;
  }
  return true;
}

}  // namespace imubench::io
