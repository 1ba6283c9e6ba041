#include "scenes/java_properties.h"

#include <cstdint>
#include <vector>

#include "core/util/text.h"

namespace furn {
namespace {

void AppendUtf8(uint32_t code_point, std::string* out) {
  *out += Utf8FromCodePoint(static_cast<char32_t>(code_point));
}

// The four hex digits of a \uXXXX escape at text[at..at+3], or -1.
int64_t HexQuad(const std::string& text, size_t at) {
  if (at + 4 > text.size() ||
      text.substr(at, 4).find_first_not_of("0123456789abcdefABCDEF") != std::string::npos)
    return -1;
  return static_cast<int64_t>(std::stoul(text.substr(at, 4), nullptr, 16));
}

// A \uXXXX escape whose 'u' is at text[*i] (Java writes a code point above
// U+FFFF as two, a UTF-16 surrogate pair: decoded as one code point; a lone
// surrogate becomes U+FFFD). Advances *i past the digits read.
void AppendUnicodeEscape(const std::string& text, size_t* i, std::string* out) {
  const int64_t unit = HexQuad(text, *i + 1);
  if (unit < 0) {
    out->push_back('u');
    return;
  }
  *i += 4;
  if (unit >= 0xD800 && unit <= 0xDBFF && *i + 2 < text.size() && text[*i + 1] == '\\' &&
      text[*i + 2] == 'u') {
    const int64_t low = HexQuad(text, *i + 3);
    if (low >= 0xDC00 && low <= 0xDFFF) {
      AppendUtf8(static_cast<uint32_t>(0x10000 + ((unit - 0xD800) << 10) + (low - 0xDC00)), out);
      *i += 6;
      return;
    }
  }
  AppendUtf8(static_cast<uint32_t>(unit), out);  // a lone surrogate: U+FFFD
}

std::string Latin1ToUtf8(const std::string& text) {
  std::string out;
  out.reserve(text.size());
  for (unsigned char c : text) AppendUtf8(c, &out);
  return out;
}

// Joins continuation lines; drops comments and blank lines. Leading white
// space of every physical line is not part of the value (Java rule).
std::vector<std::string> LogicalLines(const std::string& text) {
  std::vector<std::string> lines;
  std::string current;
  bool continuing = false;
  size_t start = 0;
  while (start <= text.size()) {
    size_t end = text.find_first_of("\r\n", start);
    if (end == std::string::npos) end = text.size();
    std::string line = text.substr(start, end - start);
    start = end + 1;
    if (end < text.size() && text[end] == '\r' && start < text.size() && text[start] == '\n') {
      ++start;
    }
    const size_t first = line.find_first_not_of(" \t\f");
    line = first == std::string::npos ? "" : line.substr(first);
    if (!continuing && (line.empty() || line[0] == '#' || line[0] == '!')) {
      if (end >= text.size()) break;
      continue;
    }
    size_t backslashes = 0;
    while (backslashes < line.size() && line[line.size() - 1 - backslashes] == '\\') {
      ++backslashes;
    }
    continuing = backslashes % 2 == 1;
    if (continuing) line.pop_back();
    current += line;
    if (!continuing) {
      lines.push_back(current);
      current.clear();
    }
    if (end >= text.size()) break;
  }
  if (!current.empty()) lines.push_back(current);
  return lines;
}

std::string Unescape(const std::string& text) {
  std::string out;
  for (size_t i = 0; i < text.size(); ++i) {
    if (text[i] != '\\' || i + 1 == text.size()) {
      out.push_back(text[i]);
      continue;
    }
    const char c = text[++i];
    switch (c) {
      case 't':
        out.push_back('\t');
        break;
      case 'n':
        out.push_back('\n');
        break;
      case 'r':
        out.push_back('\r');
        break;
      case 'f':
        out.push_back('\f');
        break;
      case 'u':
        AppendUnicodeEscape(text, &i, &out);
        break;
      default:
        out.push_back(c);
        break;
    }
  }
  return out;
}

}  // namespace

std::map<std::string, std::string> ParseJavaProperties(const std::string& raw_text) {
  const std::string text = IsValidUtf8(raw_text) ? raw_text : Latin1ToUtf8(raw_text);
  std::map<std::string, std::string> properties;
  for (const std::string& line : LogicalLines(text)) {
    size_t key_end = 0;
    while (key_end < line.size()) {
      const char c = line[key_end];
      if (c == '\\') {
        key_end += 2;
        continue;
      }
      if (c == '=' || c == ':' || c == ' ' || c == '\t' || c == '\f') break;
      ++key_end;
    }
    key_end = std::min(key_end, line.size());
    size_t value_start = key_end;
    while (value_start < line.size() &&
           (line[value_start] == ' ' || line[value_start] == '\t' || line[value_start] == '\f')) {
      ++value_start;
    }
    if (value_start < line.size() && (line[value_start] == '=' || line[value_start] == ':')) {
      ++value_start;
      while (value_start < line.size() &&
             (line[value_start] == ' ' || line[value_start] == '\t' || line[value_start] == '\f')) {
        ++value_start;
      }
    }
    properties[Unescape(line.substr(0, key_end))] = Unescape(line.substr(value_start));
  }
  return properties;
}

}  // namespace furn
