#include "drivers/dbc_parser.h"

#include <cctype>
#include <charconv>
#include <set>

namespace imubench::drivers {
namespace {

struct Token {
  enum Kind { kWord, kString, kPunct, kEnd } kind = kEnd;
  std::string text;
  int line = 0;
  int column = 0;
};

bool isWordChar(char c) {
  return std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '.' || c == '+' ||
         c == '-';
}

// Splits DBC text into words, strings and punctuation, remembering line and column. Returns
// false (with a diagnostic) on an unterminated string or a stray character.
bool tokenize(std::string_view text, std::vector<Token>& out, io::Diagnostics& diag) {
  int line = 1;
  int col = 1;
  std::size_t i = 0;
  auto advance = [&](std::size_t n) {
    for (std::size_t k = 0; k < n; ++k) {
      if (text[i] == '\n') {
        ++line;
        col = 1;
      } else {
        ++col;
      }
      ++i;
    }
  };
  while (i < text.size()) {
    const char c = text[i];
    if (c == ' ' || c == '\t' || c == '\r' || c == '\n') {
      advance(1);
      continue;
    }
    if (c == '/' && i + 1 < text.size() && text[i + 1] == '/') {  // comment to end of line
      while (i < text.size() && text[i] != '\n') advance(1);
      continue;
    }
    Token t;
    t.line = line;
    t.column = col;
    if (c == '"') {
      t.kind = Token::kString;
      advance(1);
      while (i < text.size() && text[i] != '"') {
        if (text[i] == '\\' && i + 1 < text.size()) {
          t.text += text[i + 1];
          advance(2);
          continue;
        }
        t.text += text[i];
        advance(1);
      }
      if (i >= text.size()) {
        diag.error(t.line, t.column, "unterminated string");
        return false;
      }
      advance(1);
    } else if (isWordChar(c)) {
      t.kind = Token::kWord;
      while (i < text.size() && isWordChar(text[i])) {
        t.text += text[i];
        advance(1);
      }
    } else if (std::string_view(":;|@()[],").find(c) != std::string_view::npos) {
      t.kind = Token::kPunct;
      t.text = std::string(1, c);
      advance(1);
    } else {
      diag.error(line, col, std::string("unexpected character '") + c + "'");
      return false;
    }
    out.push_back(std::move(t));
  }
  Token end;
  end.line = line;
  end.column = col;
  out.push_back(end);
  return true;
}

class Parser {
 public:
  Parser(std::vector<Token> tokens, io::Diagnostics& diag)
      : toks_(std::move(tokens)), diag_(diag) {}

  std::optional<DbcDatabase> run() {
    while (peek().kind != Token::kEnd) {
      if (!statement()) return std::nullopt;
    }
    if (!validate()) return std::nullopt;
    return std::move(db_);
  }

 private:
  const Token& peek(std::size_t k = 0) const { return toks_[std::min(pos_ + k, toks_.size() - 1)]; }
  const Token& next() {
    const Token& t = peek();
    if (pos_ < toks_.size() - 1) ++pos_;
    return t;
  }
  bool fail(const Token& at, std::string why) {
    diag_.error(at.line, at.column, std::move(why));
    return false;
  }
  bool expectPunct(const char* p, const char* context) {
    const Token& t = next();
    if (t.kind != Token::kPunct || t.text != p) {
      return fail(t, std::string("expected '") + p + "' " + context + ", found '" + t.text + "'");
    }
    return true;
  }
  bool word(std::string* out, const char* what) {
    const Token& t = next();
    if (t.kind != Token::kWord) return fail(t, std::string("expected ") + what);
    *out = t.text;
    return true;
  }
  bool number(double* out, const char* what) {
    const Token& t = next();
    if (t.kind == Token::kWord) {
      const char* b = t.text.data();
      const char* e = b + t.text.size();
      if (*b == '+') ++b;
      auto r = std::from_chars(b, e, *out);
      if (r.ec == std::errc() && r.ptr == e) return true;
    }
    return fail(t, std::string("expected a number for ") + what + ", found '" + t.text + "'");
  }
  bool integer(std::uint64_t* out, const char* what) {
    const Token& t = next();
    if (t.kind == Token::kWord && !t.text.empty()) {
      int base = 10;
      std::string_view sv = t.text;
      if (sv.size() > 2 && sv[0] == '0' && (sv[1] == 'x' || sv[1] == 'X')) {
        base = 16;
        sv.remove_prefix(2);
      }
      auto r = std::from_chars(sv.data(), sv.data() + sv.size(), *out, base);
      if (r.ec == std::errc() && r.ptr == sv.data() + sv.size()) return true;
    }
    return fail(
        t, std::string("expected an unsigned integer for ") + what + ", found '" + t.text + "'");
  }
  void skipLine(int line) {
    while (peek().kind != Token::kEnd && peek().line == line) next();
  }
  bool skipToSemicolon(const Token& start) {
    while (true) {
      const Token& t = next();
      if (t.kind == Token::kEnd)
        return fail(start, "statement '" + start.text + "' has no terminating ';'");
      if (t.kind == Token::kPunct && t.text == ";") return true;
    }
  }

  bool statement() {
    const Token& kw = next();
    if (kw.kind != Token::kWord) return fail(kw, "expected a keyword, found '" + kw.text + "'");
    const std::string& k = kw.text;
    if (k == "VERSION") {
      const Token& v = next();
      if (v.kind != Token::kString) return fail(v, "VERSION needs a quoted string");
      db_.version = v.text;
      return true;
    }
    if (k == "NS_") {
      if (!expectPunct(":", "after NS_")) return false;
      // The new-symbols list: indented lines (or the rest of the NS_ line).
      while (peek().kind != Token::kEnd && (peek().line == kw.line || peek().column > 1)) next();
      return true;
    }
    if (k == "BS_") {
      if (!expectPunct(":", "after BS_")) return false;
      skipLine(kw.line);
      return true;
    }
    if (k == "BU_") {
      if (!expectPunct(":", "after BU_")) return false;
      while (peek().kind == Token::kWord && peek().line == kw.line)
        db_.nodes.push_back(next().text);
      return true;
    }
    if (k == "BO_") return message(kw);
    if (k == "SG_") return signal(kw);
    if (k == "SIG_VALTYPE_") return valtype(kw);
    static const std::set<std::string> kIgnored = {
        "CM_",          "BA_DEF_",         "BA_DEF_DEF_", "BA_",        "VAL_",
        "VAL_TABLE_",   "BO_TX_BU_",       "EV_",         "SIG_GROUP_", "BA_DEF_REL_",
        "BA_REL_",      "BA_DEF_DEF_REL_", "BU_SG_REL_",  "BU_EV_REL_", "BU_BO_REL_",
        "ENVVAR_DATA_", "CAT_DEF_",        "CAT_",        "FILTER"};
    if (kIgnored.count(k)) return skipToSemicolon(kw);
    if (k == "SG_MUL_VAL_")
      return fail(kw, "extended signal multiplexing (SG_MUL_VAL_) is not supported");
    if (k == "SGTYPE_" || k == "SIG_TYPE_REF_" || k == "SGTYPE_VAL_")
      return fail(kw, "signal type definitions (" + k + ") are not supported");
    return fail(kw, "unknown or unsupported statement '" + k + "'");
  }

  bool message(const Token& kw) {
    DbcMessage m;
    m.line = kw.line;
    std::uint64_t id = 0;
    std::uint64_t dlc = 0;
    const Token& id_tok = peek();
    if (!integer(&id, "the message id")) return false;
    if (!word(&m.name, "a message name")) return false;
    if (!expectPunct(":", "after the message name")) return false;
    const Token& dlc_tok = peek();
    if (!integer(&dlc, "the message length")) return false;
    if (peek().kind == Token::kWord && peek().line == kw.line) m.transmitter = next().text;
    if (m.name == "VECTOR__INDEPENDENT_SIG_MSG") {  // container of unplaced signals: not a frame
      current_ = nullptr;
      skip_signals_ = true;
      return true;
    }
    skip_signals_ = false;
    if (id & 0x80000000ULL) {
      m.extended = true;
      id &= 0x1FFFFFFFULL;
      if (id > 0x1FFFFFFF) return fail(id_tok, "extended message id exceeds 29 bits");
    } else if (id > 0x7FF) {
      return fail(id_tok, "standard message id " + std::to_string(id) +
                              " exceeds 11 bits (extended ids have bit 31 set)");
    }
    m.id = static_cast<std::uint32_t>(id);
    if (dlc > 64)
      return fail(dlc_tok, "message length " + std::to_string(dlc) + " exceeds 64 bytes");
    m.length = static_cast<int>(dlc);
    for (const auto& other : db_.messages) {
      if (other.id == m.id && other.extended == m.extended)
        return fail(id_tok, "duplicate message id (first defined at line " +
                                std::to_string(other.line) + ")");
      if (other.name == m.name) return fail(kw, "duplicate message name '" + m.name + "'");
    }
    db_.messages.push_back(std::move(m));
    current_ = &db_.messages.back();
    return true;
  }

  bool signal(const Token& kw) {
    if (current_ == nullptr && !skip_signals_) return fail(kw, "SG_ outside a BO_ message");
    DbcSignal s;
    s.line = kw.line;
    if (!word(&s.name, "a signal name")) return false;
    if (peek().kind == Token::kWord) {
      return fail(peek(), "multiplexed signals ('" + peek().text + "') are not supported");
    }
    if (!expectPunct(":", "after the signal name")) return false;
    std::uint64_t start = 0;
    std::uint64_t len = 0;
    if (!integer(&start, "the start bit")) return false;
    if (!expectPunct("|", "between start bit and length")) return false;
    if (!integer(&len, "the signal length")) return false;
    if (!expectPunct("@", "before byte order")) return false;
    const Token& os = next();
    if (os.kind != Token::kWord || os.text.size() != 2 ||
        (os.text[0] != '0' && os.text[0] != '1') || (os.text[1] != '+' && os.text[1] != '-')) {
      return fail(os, "byte order and sign must be one of 1+ 1- 0+ 0-, found '" + os.text + "'");
    }
    if (start > 511 || len < 1 || len > 64)
      return fail(os, "start bit must be 0..511 and length 1..64");
    s.coding.start_bit = static_cast<int>(start);
    s.coding.length = static_cast<int>(len);
    s.coding.order = os.text[0] == '1' ? ByteOrder::kLittleEndian : ByteOrder::kBigEndian;
    s.coding.is_signed = os.text[1] == '-';
    if (!expectPunct("(", "before factor")) return false;
    if (!number(&s.coding.factor, "the factor")) return false;
    if (!expectPunct(",", "between factor and offset")) return false;
    if (!number(&s.coding.offset, "the offset")) return false;
    if (!expectPunct(")", "after offset")) return false;
    if (!expectPunct("[", "before minimum")) return false;
    if (!number(&s.minimum, "the minimum")) return false;
    if (!expectPunct("|", "between minimum and maximum")) return false;
    if (!number(&s.maximum, "the maximum")) return false;
    if (!expectPunct("]", "after maximum")) return false;
    const Token& unit = next();
    if (unit.kind != Token::kString) return fail(unit, "expected the quoted unit");
    s.unit = unit.text;
    // Receivers: node names separated by commas, on the same line.
    while (peek().kind != Token::kEnd && peek().line == kw.line &&
           (peek().kind == Token::kWord || (peek().kind == Token::kPunct && peek().text == ",")))
      next();
    if (skip_signals_) return true;
    for (const auto& other : current_->signals) {
      if (other.name == s.name)
        return fail(kw, "duplicate signal '" + s.name + "' in message '" + current_->name + "'");
    }
    current_->signals.push_back(std::move(s));
    return true;
  }

  bool valtype(const Token& kw) {
    std::uint64_t id = 0;
    std::string name;
    std::uint64_t type = 0;
    if (!integer(&id, "the message id")) return false;
    if (!word(&name, "a signal name")) return false;
    if (!expectPunct(":", "in SIG_VALTYPE_")) return false;
    const Token& type_tok = peek();
    if (!integer(&type, "the value type")) return false;
    if (!expectPunct(";", "at the end of SIG_VALTYPE_")) return false;
    const bool ext = (id & 0x80000000ULL) != 0;
    id &= 0x1FFFFFFFULL;
    for (auto& m : db_.messages) {
      if (m.id != id || m.extended != ext) continue;
      for (auto& s : m.signals) {
        if (s.name != name) continue;
        if (type == 0) {
          s.coding.type = ValueType::kInteger;
        } else if (type == 1) {
          if (s.coding.length != 32)
            return fail(type_tok, "float signal '" + name + "' must be 32 bits long");
          s.coding.type = ValueType::kFloat32;
        } else if (type == 2) {
          if (s.coding.length != 64)
            return fail(type_tok, "double signal '" + name + "' must be 64 bits long");
          s.coding.type = ValueType::kFloat64;
        } else {
          return fail(type_tok, "SIG_VALTYPE_ must be 0, 1 (float) or 2 (double)");
        }
        return true;
      }
      return fail(kw,
                  "SIG_VALTYPE_ names unknown signal '" + name + "' of message '" + m.name + "'");
    }
    return fail(kw, "SIG_VALTYPE_ names unknown message id " + std::to_string(id));
  }

  bool validate() {
    bool ok = true;
    for (const auto& m : db_.messages) {
      for (const auto& s : m.signals) {
        std::string why;
        if (!s.coding.IsValid(&why)) {
          diag_.error(s.line, 0, "signal '" + s.name + "': " + why);
          ok = false;
          continue;
        }
        const int need = s.coding.bytesNeeded();
        if (need > m.length) {
          diag_.error(s.line, 0,
                      "signal '" + s.name + "' needs " + std::to_string(need) +
                          " bytes but message '" + m.name + "' is " + std::to_string(m.length) +
                          " bytes long");
          ok = false;
        }
      }
    }
    return ok;
  }

  std::vector<Token> toks_;
  std::size_t pos_ = 0;
  io::Diagnostics& diag_;
  DbcDatabase db_;
  DbcMessage* current_ = nullptr;  // points into db_.messages (stable: reserved below)
  bool skip_signals_ = false;

 public:
  void reserve(std::size_t n) { db_.messages.reserve(n); }
};

}  // namespace

const DbcSignal* DbcMessage::findSignal(std::string_view signal_name) const {
  for (const auto& s : signals)
    if (s.name == signal_name) return &s;
  return nullptr;
}

const DbcMessage* DbcDatabase::findMessage(std::string_view message_name) const {
  for (const auto& m : messages)
    if (m.name == message_name) return &m;
  return nullptr;
}

std::optional<DbcDatabase> parseDbc(std::string_view text, io::Diagnostics& diag) {
  std::vector<Token> tokens;
  if (!tokenize(text, tokens, diag)) return std::nullopt;
  std::size_t bo_count = 0;
  for (const auto& t : tokens)
    if (t.kind == Token::kWord && t.text == "BO_") ++bo_count;
  Parser p(std::move(tokens), diag);
  p.reserve(bo_count);  // pointers into the message list stay valid while parsing
  return p.run();
}

std::optional<DbcDatabase> loadDbcFile(const std::string& path, io::Diagnostics& diag) {
  auto text = io::readTextFile(path, "DBC", diag);
  if (!text) return std::nullopt;
  return parseDbc(*text, diag);
}

}  // namespace imubench::drivers
