#include "core/util/text.h"

#include <cstdint>
#include <cstdio>

namespace furn {
namespace {

constexpr char32_t kReplacement = 0xFFFD;

// Decodes one code point at text[*at], advancing *at; ill-formed input gives
// kIllFormed and advances by one byte (so decoding always progresses).
constexpr char32_t kIllFormed = 0xFFFFFFFF;
char32_t DecodeOne(std::string_view text, size_t* at) {
  const auto byte = [&](size_t k) { return static_cast<uint8_t>(text[k]); };
  const uint8_t lead = byte(*at);
  if (lead < 0x80) {
    ++*at;
    return lead;
  }
  int length = 0;
  char32_t code = 0, least = 0;
  if (lead >= 0xC2 && lead <= 0xDF) {
    length = 2, code = lead & 0x1F, least = 0x80;
  } else if (lead >= 0xE0 && lead <= 0xEF) {
    length = 3, code = lead & 0x0F, least = 0x800;
  } else if (lead >= 0xF0 && lead <= 0xF4) {
    length = 4, code = lead & 0x07, least = 0x10000;
  }
  if (length == 0 || *at + length > text.size()) {
    ++*at;
    return kIllFormed;
  }
  for (int k = 1; k < length; ++k) {
    const uint8_t next = byte(*at + k);
    if ((next & 0xC0) != 0x80) {
      ++*at;
      return kIllFormed;
    }
    code = (code << 6) | (next & 0x3F);
  }
  if (code < least || code > 0x10FFFF || (code >= 0xD800 && code <= 0xDFFF)) {
    ++*at;
    return kIllFormed;
  }
  *at += length;
  return code;
}

bool IsControl(char32_t code) {
  return code < 0x20 || (code >= 0x7F && code <= 0x9F) || code == 0x2028 || code == 0x2029;
}

}  // namespace

std::string Utf8FromCodePoint(char32_t code) {
  if (code > 0x10FFFF || (code >= 0xD800 && code <= 0xDFFF)) code = kReplacement;
  std::string out;
  if (code < 0x80) {
    out += static_cast<char>(code);
  } else if (code < 0x800) {
    out += static_cast<char>(0xC0 | (code >> 6));
    out += static_cast<char>(0x80 | (code & 0x3F));
  } else if (code < 0x10000) {
    out += static_cast<char>(0xE0 | (code >> 12));
    out += static_cast<char>(0x80 | ((code >> 6) & 0x3F));
    out += static_cast<char>(0x80 | (code & 0x3F));
  } else {
    out += static_cast<char>(0xF0 | (code >> 18));
    out += static_cast<char>(0x80 | ((code >> 12) & 0x3F));
    out += static_cast<char>(0x80 | ((code >> 6) & 0x3F));
    out += static_cast<char>(0x80 | (code & 0x3F));
  }
  return out;
}

bool IsValidUtf8(std::string_view text) {
  for (size_t at = 0; at < text.size();) {
    if (DecodeOne(text, &at) == kIllFormed) return false;
  }
  return true;
}

std::string ValidUtf8(std::string_view text) {
  std::string out;
  out.reserve(text.size());
  for (size_t at = 0; at < text.size();) {
    const size_t before = at;
    const char32_t code = DecodeOne(text, &at);
    if (code == kIllFormed)
      out += Utf8FromCodePoint(kReplacement);
    else
      out.append(text.substr(before, at - before));
  }
  return out;
}

std::string PrintableText(std::string_view text) {
  std::string out;
  out.reserve(text.size());
  for (size_t at = 0; at < text.size();) {
    const size_t before = at;
    const char32_t code = DecodeOne(text, &at);
    if (!IsControl(code)) {
      out += code == kIllFormed ? Utf8FromCodePoint(kReplacement)
                                : std::string(text.substr(before, at - before));
      continue;
    }
    char escaped[16];
    if (code == '\n')
      std::snprintf(escaped, sizeof(escaped), "\\n");
    else if (code == '\t')
      std::snprintf(escaped, sizeof(escaped), "\\t");
    else if (code == '\r')
      std::snprintf(escaped, sizeof(escaped), "\\r");
    else if (code < 0x100)
      std::snprintf(escaped, sizeof(escaped), "\\x%02X", static_cast<unsigned>(code));
    else
      std::snprintf(escaped, sizeof(escaped), "\\u%04X", static_cast<unsigned>(code));
    out += escaped;
  }
  return out;
}

}  // namespace furn
