#pragma once
// Edit distances between names, for the "close names" and "did you mean"
// hints of error messages (clip lookup, query fields).
#include <cstddef>
#include <string>
#include <string_view>
#include <vector>

namespace mocap {

/// Levenshtein distance: the fewest single-character insertions, deletions
/// and substitutions that turn `a` into `b` (bytes compared as they are;
/// 0 for equal strings, the other's length when one is empty).
std::size_t edit_distance(std::string_view a, std::string_view b);

/// `s` with ASCII letters in lower case (other bytes unchanged), so that
/// edit_distance(ascii_lower(a), ascii_lower(b)) compares without case.
std::string ascii_lower(std::string_view s);

/// The name of `names` nearest `key` ignoring case, when within
/// `max_distance` edits (the first of equally near ones); "" when none is
/// (and for a key equal to a name but for case only: distance 0 counts).
std::string closest_name(std::string_view key, const std::vector<std::string>& names,
                         std::size_t max_distance = 2);

}  // namespace mocap
