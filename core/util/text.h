// Text from files someone else wrote (catalog names, CAD model names, a
// run's kind, a model file's notes) is data: before it reaches JSON, a
// terminal or a figure it is made valid UTF-8, and before it is printed its
// control characters are made visible.
//
//   Require(IsValidUtf8(name), path + ": entry name is not valid UTF-8");
//   std::cout << PrintableText(model.chosen_on) << "\n";  // no ESC, no newline
#pragma once

#include <string>
#include <string_view>

namespace furn {

// Whether `text` is well-formed UTF-8 (no overlong forms, no surrogates, no
// code point above U+10FFFF).
bool IsValidUtf8(std::string_view text);

// `text` with every ill-formed byte sequence replaced by U+FFFD.
std::string ValidUtf8(std::string_view text);

// ValidUtf8(text) with control characters (C0, DEL, C1) and the line and
// paragraph separators U+2028 / U+2029 written as \n, \t, \r, \xNN or
// \uNNNN: one line on a terminal, no escape sequence, nothing a reader takes
// for two lines.
std::string PrintableText(std::string_view text);

// A code point as UTF-8 (U+0000..U+10FFFF, surrogates excluded; others: U+FFFD).
std::string Utf8FromCodePoint(char32_t code_point);

}  // namespace furn
