// The process's input limits (input_limits.hpp).
#include "mocap/common/util/input_limits.hpp"

#include <stdexcept>

namespace mocap {
namespace {

InputLimits g_limits;

}  // namespace

const InputLimits& input_limits() {
  return g_limits;
}

void set_input_limits(const InputLimits& limits) {
  if (limits.bvh_bytes == 0) throw std::invalid_argument("BVH file limit must be > 0");
  if (limits.json_file_bytes == 0) throw std::invalid_argument("JSON file limit must be > 0");
  if (limits.batch_bytes == 0) throw std::invalid_argument("batch file limit must be > 0");
  if (limits.query_frames < 2) throw std::invalid_argument("query frame limit must be >= 2");
  if (limits.bvh_joints == 0) throw std::invalid_argument("joint limit must be > 0");
  g_limits = limits;
}

}  // namespace mocap
