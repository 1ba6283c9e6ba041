// Parser for Java .properties files (java.util.Properties.load rules): comment
// lines start with '#' or '!', the key ends at the first unescaped '=', ':' or
// white space, a line ending in an odd number of backslashes continues, and
// \t \n \r \f \uXXXX escapes are decoded. Input is UTF-8 when it is valid
// UTF-8, ISO-8859-1 otherwise (as Java's PropertyResourceBundle reads); output
// is UTF-8.
//
//   std::map<std::string, std::string> p = ParseJavaProperties(text);
//   std::string name = p["name#1"];
#pragma once

#include <map>
#include <string>

namespace furn {

std::map<std::string, std::string> ParseJavaProperties(const std::string& text);

}  // namespace furn
