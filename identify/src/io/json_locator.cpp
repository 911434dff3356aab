#include "io/json_locator.hpp"

#include <set>

#include "kincal/identify/input_error.hpp"

namespace kincal::identify::detail {

std::string child_path(const std::string& parent, const std::string& key) {
  std::string out = parent + "/";
  for (char c : key) {
    if (c == '~')
      out += "~0";
    else if (c == '/')
      out += "~1";
    else
      out += c;
  }
  return out;
}

std::string child_path(const std::string& parent, std::size_t index) { return parent + "/" + std::to_string(index); }

std::size_t JsonLocations::value_offset(std::string path) const {
  for (;;) {
    const auto it = value.find(path);
    if (it != value.end()) return it->second;
    if (path.empty()) return 0;
    const std::size_t slash = path.rfind('/');
    path = slash == std::string::npos ? std::string() : path.substr(0, slash);
  }
}

std::size_t JsonLocations::key_offset(const std::string& path) const {
  const auto it = key.find(path);
  return it != key.end() ? it->second : value_offset(path);
}

namespace {

class Walker {
 public:
  Walker(std::string_view text, JsonLocations& out) : t_(text), out_(out) {}

  void run() {
    if (t_.size() >= 3 && t_.substr(0, 3) == "\xEF\xBB\xBF") i_ = 3;  // UTF-8 BOM
    value("", 0);
  }

 private:
  static constexpr int kMaxDepth = 256;

  void ws() {
    while (i_ < t_.size() && (t_[i_] == ' ' || t_[i_] == '\t' || t_[i_] == '\n' || t_[i_] == '\r')) ++i_;
  }
  bool at(char c) const { return i_ < t_.size() && t_[i_] == c; }

  // Raw text of a string token (escapes kept as written), i_ past the quote.
  std::string string_token() {
    std::string s;
    ++i_;  // opening quote
    while (i_ < t_.size() && t_[i_] != '"') {
      if (t_[i_] == '\\' && i_ + 1 < t_.size()) {
        s += t_[i_++];
      }
      s += t_[i_++];
    }
    if (i_ < t_.size()) ++i_;  // closing quote
    return s;
  }

  void value(const std::string& path, int depth) {
    ws();
    if (i_ >= t_.size() || depth > kMaxDepth) return;
    out_.value.emplace(path, i_);
    const char c = t_[i_];
    if (c == '{') {
      ++i_;
      std::set<std::string> seen;
      for (;;) {
        ws();
        if (i_ >= t_.size()) return;
        if (at('}')) {
          ++i_;
          return;
        }
        if (at(',')) {
          ++i_;
          continue;
        }
        if (!at('"')) return;  // not valid JSON: stop
        const std::size_t key_at = i_;
        const std::string key = string_token();
        const std::string p = child_path(path, key);
        if (!seen.insert(key).second) out_.duplicates.push_back({p, key_at});
        out_.key.emplace(p, key_at);
        ws();
        if (!at(':')) return;
        ++i_;
        value(p, depth + 1);
      }
    } else if (c == '[') {
      ++i_;
      std::size_t index = 0;
      for (;;) {
        ws();
        if (i_ >= t_.size()) return;
        if (at(']')) {
          ++i_;
          return;
        }
        if (at(',')) {
          ++i_;
          continue;
        }
        const std::size_t before = i_;
        value(child_path(path, index++), depth + 1);
        if (i_ == before) return;  // no progress: not valid JSON
      }
    } else if (c == '"') {
      string_token();
    } else {
      while (i_ < t_.size() && t_[i_] != ',' && t_[i_] != ']' && t_[i_] != '}' && t_[i_] != ' ' && t_[i_] != '\n' &&
             t_[i_] != '\r' && t_[i_] != '\t')
        ++i_;
    }
  }

  std::string_view t_;
  JsonLocations& out_;
  std::size_t i_ = 0;
};

}  // namespace

void check_json_depth(std::string_view text, const std::string& file, int max_depth) {
  int depth = 0;
  bool in_string = false;
  for (std::size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    if (in_string) {
      if (c == '\\')
        ++i;  // the escaped character
      else if (c == '"')
        in_string = false;
    } else if (c == '"') {
      in_string = true;
    } else if (c == '{' || c == '[') {
      if (++depth > max_depth) {
        const TextPosition p = position_of(text, i);
        throw InputError(file, p.line, p.column,
                         "JSON nested deeper than " + std::to_string(max_depth) + " levels (no kincal file needs more than 5)");
      }
    } else if (c == '}' || c == ']') {
      --depth;
    }
  }
}

nlohmann::json parse_json_text(const std::string& text, const std::string& file) {
  check_json_depth(text, file);
  try {
    return nlohmann::json::parse(text);
  } catch (const nlohmann::json::parse_error& e) {
    // e.byte is 1-based: the byte at which the parser stopped.
    const TextPosition p = position_of(text, e.byte > 0 ? e.byte - 1 : 0);
    std::string what = e.what();
    // "[json.exception.parse_error.101] parse error at line 1, column 2: syntax error while ..." → the tail.
    const std::size_t colon = what.find(": ");
    if (colon != std::string::npos) what = what.substr(colon + 2);
    throw InputError(file, p.line, p.column, "malformed JSON: " + what);
  } catch (const nlohmann::json::exception& e) {
    // out_of_range.406 "number overflow parsing '1e999'" carries no byte
    // position: point at the number, the first occurrence of the quoted
    // token outside strings that is a whole number (not part of a longer one).
    std::string what = e.what();
    const std::size_t bracket = what.find("] ");
    if (bracket != std::string::npos) what = what.substr(bracket + 2);
    std::size_t at = 0;
    const std::size_t q1 = what.find('\''), q2 = what.rfind('\'');
    if (q1 != std::string::npos && q2 > q1) {
      const std::string token = what.substr(q1 + 1, q2 - q1 - 1);
      const auto numeric = [](char c) {
        return (c >= '0' && c <= '9') || c == '.' || c == 'e' || c == 'E' || c == '+' || c == '-';
      };
      bool in_string = false;
      for (std::size_t i = 0; i < text.size(); ++i) {
        const char c = text[i];
        if (in_string) {
          if (c == '\\')
            ++i;
          else if (c == '"')
            in_string = false;
        } else if (c == '"') {
          in_string = true;
        } else if (text.compare(i, token.size(), token) == 0 && (i == 0 || !numeric(text[i - 1])) &&
                   (i + token.size() == text.size() || !numeric(text[i + token.size()]))) {
          at = i;
          break;
        }
      }
    }
    const TextPosition p = position_of(text, at);
    throw InputError(file, p.line, p.column, "invalid JSON value: " + what + " (numbers must be finite doubles)");
  }
}

JsonLocations locate_json(std::string_view text) {
  JsonLocations out;
  Walker(text, out).run();
  return out;
}

}  // namespace kincal::identify::detail
