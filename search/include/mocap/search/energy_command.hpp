#pragma once
// `mocap-search energy`: h and g for the transition between two capture frames
// (docs/cli.md, docs/energy.md).
//
//   mocap-search energy --from FILE:FRAME --to FILE:FRAME [--transition-time S]
//                       [--character C.json] [--unit U] [--json]
//
// FRAME is 0-based. Each state is that frame with its clip velocities and
// accelerations (finite differences over its own clip, dynamics.hpp). The
// character's body is built on the --from file's skeleton (length scales
// applied) and used for both. When the --to file is another rig
// (retarget.hpp same_rig), its clip is retargeted onto the --from skeleton
// (every frame, so its rates are the retargeted motion's; the --from clip's
// frames give the rig's typical pose, typical_local_rotations) and h and g sum
// only the terms of the segments both rigs share (RetargetMap::compared), as
// the search compares a query frame of another rig with database frames.
// --unit applies to both files (default: detected per file).
#include <filesystem>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "mocap/common/dynamics/work_energy.hpp"
#include "mocap/common/io/units.hpp"

namespace mocap {

/// "FILE:FRAME" split at the last ':'; throws InputError("<option>", 0, ...) when
/// the frame is not a non-negative integer or the file part is empty.
struct FrameSpec {
  std::filesystem::path file;
  std::size_t frame = 0;
};
FrameSpec parse_frame_spec(const std::string& text, const std::string& option);

struct EnergyCommandOptions {
  FrameSpec from;
  FrameSpec to;
  /// T of the transition, seconds (> 0).
  double transition_time_s = 0.5;
  /// Character file (docs/character.md); empty = default character.
  std::filesystem::path character;
  /// nullopt = detect per file (units.hpp).
  std::optional<LengthUnit> unit;
  /// W's price of unsupported force (work_energy.hpp).
  WorkEnergyParams work;
};

/// W (work_energy.hpp) and its parts, joules, summed over one step or many:
/// joint + ground + residual work + unsupported = total.
struct WorkEnergySums {
  double total_J = 0.0;
  double joint_J = 0.0;
  double ground_J = 0.0;
  double residual_work_J = 0.0;
  double unsupported_J = 0.0;
  /// Adds one step's terms (their total() to total_J).
  void add(const WorkEnergyTerms& step);
};

struct EnergyTermReport {
  std::string name;
  bool is_joint = false;  // "joint" vs "segment"
  double h_J = 0.0;
  double g_J = 0.0;
};

struct EnergyReport {
  double h_J = 0.0;
  double g_J = 0.0;
  std::vector<EnergyTermReport> terms;
  // Context (also printed).
  FrameSpec from;
  FrameSpec to;
  double transition_time_s = 0.0;
  std::string character;
  std::string from_unit;
  std::string to_unit;
  double total_mass_kg = 0.0;
  std::size_t from_contacts = 0;
  std::size_t to_contacts = 0;
  double residual_work_J = 0.0;
  double residual_impulse_J = 0.0;
  /// W, the work energy (work_energy.hpp), and its parts (the whole body,
  /// also across rigs).
  WorkEnergySums w;
  /// The --to file is another rig, retargeted onto the --from skeleton: h_J,
  /// g_J and `terms` cover only the compared segments, whose classes
  /// compared_classes names (retarget.hpp class_key_name).
  bool cross_rig = false;
  std::vector<std::string> compared_classes;
};

/// Runs the command. Bad input (unreadable / malformed file, frame out of
/// range, a --to skeleton of another rig that cannot be retargeted (no
/// pelvis), bad character file, T <= 0) throws InputError.
EnergyReport run_energy_command(const EnergyCommandOptions& options);

/// {"h_J", "g_J", "terms": [{"name", "kind", "h_J", "g_J"}], "from": {"file", "frame"},
///  "to": {...}, "transition_time_s", "character", "total_mass_kg", "unit": {"from", "to"},
///  "contacts": {"from", "to"}, "residual": {"work_J", "impulse_J"}, "w_J",
///  "w_parts": {"joint_J", "ground_J", "residual_work_J", "unsupported_J"},
///  "cross_rig", "compared_classes" (only when cross_rig)} on one line.
std::string energy_report_json(const EnergyReport& report);
/// Human-readable table.
std::string energy_report_text(const EnergyReport& report);

/// `mocap-search energy --motion FILE.bvh [--frames S-E]`: a whole motion's
/// energy, the sum over its steps F^f -> F^(f+1), f = S .. E-1, with T = the
/// frame time and every frame's rates from the whole file's finite
/// differences (so a frame S > 0 takes its velocity from S-1 and S+1), as
/// clip_step_energies gives a database clip's own energy. It is how a made
/// motion is judged beside a captured one (docs/energy.md "Realism").
struct MotionEnergyOptions {
  std::filesystem::path file;
  /// Frames S..E (0-based, inclusive, S < E); nullopt: the whole file.
  std::optional<std::pair<std::size_t, std::size_t>> frames;
  /// Character file (docs/character.md); empty = default character.
  std::filesystem::path character;
  /// nullopt = detect (units.hpp).
  std::optional<LengthUnit> unit;
  /// W's price of unsupported force (work_energy.hpp).
  WorkEnergyParams work;
};

struct MotionEnergyReport {
  std::filesystem::path file;
  std::size_t first_frame = 0;
  std::size_t last_frame = 0;
  double frame_time_s = 0.0;
  std::string character;
  std::string unit;
  double total_mass_kg = 0.0;
  /// Sums over the steps, joules: h, g and g's parts (h + adjacent + contact
  /// + joint + residual work + residual impulse = g, to round-off).
  double h_J = 0.0;
  double g_J = 0.0;
  double adjacent_work_J = 0.0;
  double contact_work_J = 0.0;
  double joint_work_J = 0.0;
  double residual_work_J = 0.0;
  double residual_impulse_J = 0.0;
  /// Every segment's and joint's terms summed over the steps.
  std::vector<EnergyTermReport> terms;
  /// W, the work energy (work_energy.hpp), summed over the steps, and its parts.
  WorkEnergySums w;
  /// g and W of each step, joules (E - S values each).
  std::vector<double> step_g_J;
  std::vector<double> step_w_J;
  /// Frames S..E with no contact point on the ground (inverse_dynamics's
  /// contact test: near the ground and slower than contact_speed_mps).
  std::size_t no_contact_frames = 0;
  /// Largest local angular speed of a segment joint (not a body root) over
  /// the steps, rad/s, and that joint's name ("" for a motion without one).
  double peak_angular_speed_radps = 0.0;
  std::string peak_joint;
  /// Steps in which a foot or toe joint skates (docs/synthesis.md
  /// "Measures": below kSkatingHeightM in both frames, faster than
  /// kSkatingSpeedMps horizontally).
  std::size_t skating_steps = 0;
};

/// Runs `energy --motion`. Bad input (unreadable / malformed file, frames
/// outside the file or S >= E, a file of fewer than 2 frames, bad character
/// file, no body segment) throws InputError naming the file or the option.
MotionEnergyReport run_motion_energy_command(const MotionEnergyOptions& options);
/// {"motion": {"file", "first_frame", "last_frame", "steps", "frame_time_s"},
///  "h_J", "g_J", "parts": {"h_J", "adjacent_work_J", "contact_work_J",
///  "joint_work_J", "residual_work_J", "residual_impulse_J"}, "w_J", "w_parts":
///  {"joint_J", "ground_J", "residual_work_J", "unsupported_J"}, "terms":
///  [{"name", "kind", "h_J", "g_J"}], "step_g_J": [...], "step_w_J": [...], "no_contact_frames",
///  "no_contact_ratio", "peak_angular_speed_radps", "peak_joint", "skating_steps",
///  "skating_ratio", "character",
///  "total_mass_kg", "unit"} on one line.
std::string motion_energy_report_json(const MotionEnergyReport& report);
/// Human-readable summary and table.
std::string motion_energy_report_text(const MotionEnergyReport& report);

}  // namespace mocap
