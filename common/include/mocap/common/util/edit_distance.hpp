#pragma once
// Edit distances between names, for the "close names" and "did you mean"
// hints of error messages (clip lookup, query fields).
#include <cstddef>
#include <string>
#include <string_view>

namespace mocap {

/// Levenshtein distance: the fewest single-character insertions, deletions
/// and substitutions that turn `a` into `b` (bytes compared as they are;
/// 0 for equal strings, the other's length when one is empty).
std::size_t edit_distance(std::string_view a, std::string_view b);

/// `s` with ASCII letters in lower case (other bytes unchanged), so that
/// edit_distance(ascii_lower(a), ascii_lower(b)) compares without case.
std::string ascii_lower(std::string_view s);

}  // namespace mocap
