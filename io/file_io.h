// Whole-file reading shared by the io/ readers (recordings, JSON files): one read into a
// string, no iostreams.
#pragma once

#include <cstddef>
#include <functional>
#include <string>

#include "base/status.h"

namespace imubench::io {

// Reads the whole file into *out. Errors: "path: missing file", "path: cannot open: ...".
Status readWholeFile(const std::string& path, std::string* out);

// A file a user names (a plan to send or to run), read so that nothing the path names can
// block or exhaust the reader: opened O_NONBLOCK (a FIFO without a writer or a file under a
// lease returns at once), refused unless it is a regular file, refused when it has (or grows
// to) more than max_bytes. `vet`, when given, checks the opened descriptor before anything is
// read (e.g. where it really resolves); a non-empty answer refuses with that reason.
enum class UserFileError { kNone, kMissing, kBusy, kOpen, kNotRegular, kTooLarge, kRead, kVetoed };

struct UserFile {
  UserFileError error = UserFileError::kNone;
  std::string text;     // the contents, when ok()
  std::string message;  // "path: why" otherwise (never any of the file's contents)
  bool ok() const { return error == UserFileError::kNone; }
};

// limit_name says what max_bytes is ("a plan may have"): "N bytes, more than the M bytes
// <limit_name>".
UserFile readUserFile(const std::string& path, std::size_t max_bytes, const std::string& limit_name,
                      const std::function<std::string(int fd)>& vet = {});

}  // namespace imubench::io
