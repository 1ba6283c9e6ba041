#include "scenes/java_properties.h"

#include <cstdint>
#include <vector>

namespace furn {
namespace {

bool IsValidUtf8(const std::string& text) {
  size_t i = 0;
  while (i < text.size()) {
    const auto lead = static_cast<unsigned char>(text[i]);
    int continuation_bytes;
    if (lead < 0x80) {
      continuation_bytes = 0;
    } else if ((lead >> 5) == 0x6) {
      continuation_bytes = 1;
    } else if ((lead >> 4) == 0xE) {
      continuation_bytes = 2;
    } else if ((lead >> 3) == 0x1E) {
      continuation_bytes = 3;
    } else {
      return false;
    }
    if (i + continuation_bytes >= text.size() && continuation_bytes > 0) return false;
    for (int k = 1; k <= continuation_bytes; ++k) {
      if ((static_cast<unsigned char>(text[i + k]) >> 6) != 0x2) return false;
    }
    i += continuation_bytes + 1;
  }
  return true;
}

void AppendUtf8(uint32_t code_point, std::string* out) {
  if (code_point < 0x80) {
    out->push_back(static_cast<char>(code_point));
  } else if (code_point < 0x800) {
    out->push_back(static_cast<char>(0xC0 | (code_point >> 6)));
    out->push_back(static_cast<char>(0x80 | (code_point & 0x3F)));
  } else if (code_point < 0x10000) {
    out->push_back(static_cast<char>(0xE0 | (code_point >> 12)));
    out->push_back(static_cast<char>(0x80 | ((code_point >> 6) & 0x3F)));
    out->push_back(static_cast<char>(0x80 | (code_point & 0x3F)));
  } else {
    out->push_back(static_cast<char>(0xF0 | (code_point >> 18)));
    out->push_back(static_cast<char>(0x80 | ((code_point >> 12) & 0x3F)));
    out->push_back(static_cast<char>(0x80 | ((code_point >> 6) & 0x3F)));
    out->push_back(static_cast<char>(0x80 | (code_point & 0x3F)));
  }
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
        if (i + 4 < text.size() && text.substr(i + 1, 4).find_first_not_of(
                                       "0123456789abcdefABCDEF") == std::string::npos) {
          AppendUtf8(static_cast<uint32_t>(std::stoul(text.substr(i + 1, 4), nullptr, 16)), &out);
          i += 4;
        } else {
          out.push_back('u');
        }
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
