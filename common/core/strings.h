// ASCII case mapping for names, flags and file extensions.
#pragma once

#include <algorithm>
#include <cctype>
#include <string>

namespace rtpm {

/// `s` with ASCII letters in lower case (other bytes unchanged).
inline std::string toLower(std::string s) {
    std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return char(std::tolower(c)); });
    return s;
}

/// `s` with ASCII letters in upper case (other bytes unchanged).
inline std::string toUpper(std::string s) {
    std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return char(std::toupper(c)); });
    return s;
}

}  // namespace rtpm
