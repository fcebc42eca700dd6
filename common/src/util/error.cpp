#include "mocap/common/util/error.hpp"

#include <fmt/format.h>

namespace mocap {

namespace {
std::string format_input_error(const std::string& source, std::size_t line,
                               const std::string& msg) {
  if (line == 0) return fmt::format("{}: {}", source, msg);
  return fmt::format("{}:{}: {}", source, line, msg);
}
}  // namespace

InputError::InputError(std::string source, std::size_t line, std::string message)
    : std::runtime_error(format_input_error(source, line, message)),
      source_(std::move(source)),
      line_(line),
      detail_(std::move(message)) {}

}  // namespace mocap
