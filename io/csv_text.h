// Text primitives shared by io/'s CSV readers and writers (the imubench-csv/1 recording and
// the logger importer, io/logger_csv.h): a line cursor with 1-based line numbers (\n and \r\n),
// one strict number parser (std::from_chars: the whole field, finite), shortest round-trip
// number formatting, and a quoted excerpt of a bad field for messages.
#pragma once

#include <charconv>
#include <cmath>
#include <cstddef>
#include <cstring>
#include <string>
#include <string_view>

namespace imubench::io {

// Line-by-line cursor over a text with 1-based line numbers. Accepts \n and \r\n.
class LineCursor {
 public:
  explicit LineCursor(std::string_view text) : p_(text.data()), end_(text.data() + text.size()) {}

  // Next line without its terminator; false at the end of the text.
  bool next(std::string_view* line) {
    if (p_ >= end_) return false;
    const char* nl =
        static_cast<const char*>(std::memchr(p_, '\n', static_cast<size_t>(end_ - p_)));
    const char* stop = nl ? nl : end_;
    const char* e = stop;
    if (e > p_ && e[-1] == '\r') --e;
    *line = std::string_view(p_, static_cast<size_t>(e - p_));
    p_ = nl ? nl + 1 : end_;
    ++line_no_;
    return true;
  }
  long lineNo() const { return line_no_; }

 private:
  const char* p_;
  const char* end_;
  long line_no_ = 0;
};

// 'field' quoted for a message, cut at 40 characters.
std::string quoteForMessage(std::string_view s);

// Shortest text that reads back to the same double.
std::string fmtDouble(double v);

// Parses one finite decimal number occupying the whole field; *why names `column` otherwise
// (empty, not a number, out of range, NaN/infinite).
bool parseNumber(std::string_view field, std::string_view column, double* value, std::string* why);

}  // namespace imubench::io
