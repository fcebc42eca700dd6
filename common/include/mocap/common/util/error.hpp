#pragma once
// Errors for bad input (files, queries, indexes, character files).
//
// Two tiers (docs/architecture.md): bad input throws InputError with the source
// (file path or a name such as "<query 3>"), the 1-based line (0 when the
// position is not a line, e.g. a JSON field or an HDF5 dataset) and a message
// saying what was expected. `assert` is only for the program's own invariants.
#include <cstddef>
#include <stdexcept>
#include <string>

namespace mocap {

class InputError : public std::runtime_error {
 public:
  /// `source`: file path or logical name; `line`: 1-based, 0 = not applicable.
  InputError(std::string source, std::size_t line, std::string message);

  const std::string& source() const { return source_; }
  std::size_t line() const { return line_; }
  /// The message without the "source:line: " prefix.
  const std::string& detail() const { return detail_; }

 private:
  std::string source_;
  std::size_t line_;
  std::string detail_;
};

}  // namespace mocap
