// Text primitives shared by io/'s CSV readers and writers (the imubench-csv/1 recording and
// the logger importer, io/logger_csv.h): a line cursor with 1-based line numbers (\n and \r\n),
// one strict number parser (std::from_chars: the whole field, finite), shortest round-trip
// number formatting, a quoted excerpt of a bad field for messages, and a block reader that
// hands a file of any size out as whole lines through a fixed buffer (never the whole file).
#pragma once

#include <charconv>
#include <cmath>
#include <cstddef>
#include <cstring>
#include <functional>
#include <string>
#include <string_view>

#include "base/status.h"

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

// Reads `path` in large blocks (kTextBlockBytes; a longer line grows the buffer) and calls
// block(text, file_bytes) with whole lines only: every call's text ends in '\n' except the
// last, which holds the rest of the file after the last '\n' (when there is any). file_bytes
// is the file's size, for reserving output. block returns false to stop early (its own error).
// Errors: "path: missing file", "path: is a directory, expected a file", "path: cannot open:
// ...", "path: read error" (the messages of readWholeFile, io/file_io.h).
inline constexpr size_t kTextBlockBytes = size_t{4} << 20;  // fits L2/L3 reuse; 4 MB resident
Status readLineBlocks(const std::string& path,
                      const std::function<bool(std::string_view text, size_t file_bytes)>& block);

}  // namespace imubench::io
