#include "mocap/search/energy_command.hpp"
#include "mocap/common/util/json_text.hpp"

#include <fmt/format.h>

#include <charconv>
#include <cmath>
#include <nlohmann/json.hpp>

#include "mocap/common/body/body.hpp"
#include "mocap/common/body/joint_classes.hpp"
#include "mocap/common/body/retarget.hpp"
#include "mocap/common/body/skeleton.hpp"
#include "mocap/common/dynamics/dynamics.hpp"
#include "mocap/common/dynamics/energy.hpp"
#include "mocap/common/dynamics/kinematics.hpp"
#include "mocap/common/dynamics/newton_euler.hpp"
#include "mocap/common/dynamics/work_energy.hpp"
#include "mocap/common/io/bvh.hpp"
#include "mocap/common/motion/skeleton_motion.hpp"
#include "mocap/common/util/error.hpp"

namespace mocap {

FrameSpec parse_frame_spec(const std::string& text, const std::string& option) {
  const auto colon = text.rfind(':');
  if (colon == std::string::npos || colon == 0 || colon + 1 == text.size())
    throw InputError(option, 0, "expected FILE:FRAME (0-based frame), got '" + text + "'");
  const std::string frame = text.substr(colon + 1);
  std::size_t value = 0;
  const auto [ptr, ec] = std::from_chars(frame.data(), frame.data() + frame.size(), value);
  if (ec != std::errc() || ptr != frame.data() + frame.size())
    throw InputError(option, 0,
                     "frame '" + frame + "' is not a non-negative integer (FILE:FRAME, 0-based)");
  return {text.substr(0, colon), value};
}

namespace {

// One clip prepared for a character: its skeleton (length-scaled), model and
// per-frame dynamics.
struct LoadedClip {
  Skeleton skeleton;
  DynamicsModel model;
  ClipDynamics dynamics;
  std::string unit;
  // Every frame's local rotations, [f * J + j].
  std::vector<Eigen::Quaterniond> local_rotations;
};

// The frame's file read as the indexer reads it (Y up), its frame checked.
RawClip read_frame_clip(const FrameSpec& spec) {
  RawClip raw = read_bvh_file(spec.file);
  normalise_up_axis(raw, std::nullopt);  // Y up, as the indexer reads it
  if (spec.frame >= raw.frame_count)
    throw InputError(spec.file.string(), 0,
                     fmt::format("frame {} out of range: the clip has {} frames (0-based)",
                                 spec.frame, raw.frame_count));
  return raw;
}

// World poses of every frame ([f * J + j]) -> the clip's dynamics on `c`'s model.
void clip_dynamics(LoadedClip& c, std::size_t frames, double frame_time_s,
                   const std::vector<Eigen::Vector3d>& positions,
                   const std::vector<Eigen::Quaterniond>& rotations) {
  compute_clip_dynamics(c.model, frames, frame_time_s, positions.data(), rotations.data(),
                        c.dynamics);
}

LoadedClip load_clip(const FrameSpec& spec, const RawClip& raw, const Character& character,
                     LengthUnit u) {
  LoadedClip c;
  c.unit = unit_name(u);
  c.skeleton = apply_length_scales(build_skeleton(raw, unit_scale_m(u)), character);
  const Body body = build_body(c.skeleton, character);
  c.model = build_dynamics_model(c.skeleton, body);
  if (c.model.segments.empty())
    throw InputError(spec.file.string(), 0,
                     "no joint of the skeleton carries mass (no body segment recognised)");
  const std::size_t n = c.skeleton.joint_count();
  std::vector<Eigen::Vector3d> positions(raw.frame_count * n);
  std::vector<Eigen::Quaterniond> rotations(raw.frame_count * n);
  LocalPose local;
  WorldPose world;
  c.local_rotations.reserve(raw.frame_count * n);
  for (std::size_t f = 0; f < raw.frame_count; ++f) {
    local_pose_from_row(c.skeleton, raw.frame(f), local);
    c.local_rotations.insert(c.local_rotations.end(), local.rotations.begin(),
                             local.rotations.end());
    forward_kinematics(c.skeleton, local, world);
    std::copy(world.positions_m.begin(), world.positions_m.end(),
              positions.begin() + static_cast<std::ptrdiff_t>(f * n));
    std::copy(world.rotations.begin(), world.rotations.end(),
              rotations.begin() + static_cast<std::ptrdiff_t>(f * n));
  }
  clip_dynamics(c, raw.frame_count, raw.frame_time_s, positions, rotations);
  return c;
}

// The clip `raw` of another rig retargeted onto `onto`'s skeleton and body
// (retarget.hpp), every frame, so that its rates are the retargeted
// motion's finite differences, as a query frame's are.
LoadedClip load_retargeted_clip(const RawClip& raw, LengthUnit u, const LoadedClip& onto,
                                const RetargetMap& map) {
  LoadedClip c;
  c.unit = unit_name(u);
  c.skeleton = onto.skeleton;
  c.model = onto.model;
  const ClipMotion source = clip_locals_from_raw(raw, unit_scale_m(u));
  const std::size_t n = c.skeleton.joint_count();
  std::vector<Eigen::Vector3d> positions(raw.frame_count * n);
  std::vector<Eigen::Quaterniond> rotations(raw.frame_count * n);
  LocalPose local;
  WorldPose world;
  for (std::size_t f = 0; f < raw.frame_count; ++f) {
    retarget_clip_frame(map, source, f, c.skeleton, local, world);
    std::copy(world.positions_m.begin(), world.positions_m.end(),
              positions.begin() + static_cast<std::ptrdiff_t>(f * n));
    std::copy(world.rotations.begin(), world.rotations.end(),
              rotations.begin() + static_cast<std::ptrdiff_t>(f * n));
  }
  clip_dynamics(c, raw.frame_count, raw.frame_time_s, positions, rotations);
  return c;
}

// --unsupported-speed: finite and >= 0 (work_energy throws invalid_argument otherwise).
void check_work_params(const WorkEnergyParams& p) {
  if (!(p.unsupported_speed_mps >= 0.0) || !std::isfinite(p.unsupported_speed_mps))
    throw InputError("--unsupported-speed", 0, "must be a finite speed >= 0 (m/s)");
}

// "w_parts" of both reports' JSON.
nlohmann::json work_parts_json(const WorkEnergySums& w) {
  return {{"joint_J", w.joint_J},
          {"ground_J", w.ground_J},
          {"residual_work_J", w.residual_work_J},
          {"unsupported_J", w.unsupported_J}};
}

// "terms" of both reports' JSON.
nlohmann::json terms_json(const std::vector<EnergyTermReport>& terms) {
  nlohmann::json out = nlohmann::json::array();
  for (const auto& t : terms)
    out.push_back({{"name", t.name},
                   {"kind", t.is_joint ? "joint" : "segment"},
                   {"h_J", t.h_J},
                   {"g_J", t.g_J}});
  return out;
}

// The W line of both reports' text (no newline).
std::string work_line(const WorkEnergySums& w) {
  return fmt::format(
      "W = {:.6g} J = joint {:.4g} + ground {:.4g} + residual work {:.4g} + unsupported {:.4g}",
      w.total_J, w.joint_J, w.ground_J, w.residual_work_J, w.unsupported_J);
}

// The table of terms ending both reports' text.
std::string terms_table(const std::vector<EnergyTermReport>& terms) {
  std::string s = fmt::format("{:<20} {:<8} {:>12} {:>12}\n", "name", "kind", "h_J", "g_J");
  for (const auto& t : terms)
    s += fmt::format("{:<20} {:<8} {:>12.6g} {:>12.6g}\n", t.name, t.is_joint ? "joint" : "segment",
                     t.h_J, t.g_J);
  return s;
}

}  // namespace

void WorkEnergySums::add(const WorkEnergyTerms& step) {
  total_J += step.total();
  for (const double v : step.joint_J) joint_J += v;
  for (const double v : step.ground_J) ground_J += v;
  residual_work_J += step.residual_work_J;
  unsupported_J += step.unsupported_J;
}

EnergyReport run_energy_command(const EnergyCommandOptions& o) {
  // The query's range (query.cpp "transition_time"): below a millisecond the
  // velocities overflow to an infinite h and g.
  if (!(o.transition_time_s >= 1e-3 && o.transition_time_s <= 60.0))
    throw InputError("--transition-time", 0,
                     fmt::format("must be 0.001 to 60 seconds (got {})", o.transition_time_s));
  check_work_params(o.work);
  Character character;
  if (!o.character.empty()) character = read_character_file(o.character);
  const RawClip raw_a = read_frame_clip(o.from);
  const RawClip raw_b = read_frame_clip(o.to);
  const LengthUnit unit_a = o.unit ? *o.unit : detect_unit(raw_a);
  const LengthUnit unit_b = o.unit ? *o.unit : detect_unit(raw_b);
  const LoadedClip a = load_clip(o.from, raw_a, character, unit_a);
  // The --to frame of another rig is retargeted onto the --from skeleton,
  // with the --from clip's frames for the rig's typical pose (the search
  // takes its index's frames of the skeleton).
  std::optional<RetargetMap> rig;
  const Skeleton skeleton_b = build_skeleton(raw_b, unit_scale_m(unit_b));
  if (!same_rig(skeleton_b, a.skeleton)) {
    try {
      rig = make_retarget_map(skeleton_b, a.skeleton,
                              typical_local_rotations(a.local_rotations, a.skeleton.joint_count()));
    } catch (const InputError& e) {
      throw InputError(
          o.to.file.string(), 0,
          "its skeleton is another rig than that of " + o.from.file.string() + ": " + e.detail());
    }
  }
  const LoadedClip b = rig ? load_retargeted_clip(raw_b, unit_b, a, *rig)
                           : load_clip(o.to, raw_b, character, unit_b);
  const DynamicsModel& model = a.model;
  const StateView sa = a.dynamics.state(o.from.frame);
  const StateView sb = b.dynamics.state(o.to.frame);
  NewtonEulerWorkspace ws;
  FullEnergyTerms terms;
  EnergyReport r;
  r.g_J = full_energy(model, sa, sb, o.transition_time_s, ws, &terms);
  r.h_J = terms.h.total();
  if (rig) {
    // Only the segments the rigs share: h and g are the sums of their terms.
    r.cross_rig = true;
    r.h_J = r.g_J = 0.0;
    for (const auto& [c, s] : rig->compared_classes)
      r.compared_classes.push_back(class_key_name(c, s));
  }
  for (const NamedEnergyTerm& t : energy_term_names(model)) {
    const auto j = static_cast<std::size_t>(t.joint);
    if (rig && !rig->compared[j]) continue;
    const double h = t.is_joint ? terms.h.joint_J[j] : terms.h.segment_J[j];
    const double g = t.is_joint ? terms.g.joint_J[j] : terms.g.segment_J[j];
    r.terms.push_back({t.name, t.is_joint, h, g});
    if (rig) {
      r.h_J += h;
      r.g_J += g;
    }
  }
  r.from = o.from;
  r.to = o.to;
  r.transition_time_s = o.transition_time_s;
  r.character = character.name;
  r.from_unit = a.unit;
  r.to_unit = b.unit;
  r.total_mass_kg = model.total_mass_kg;
  r.from_contacts = ws.a.contact_count;
  r.to_contacts = ws.b.contact_count;
  r.residual_work_J = terms.residual_work_J;
  r.residual_impulse_J = terms.residual_impulse_J;
  WorkEnergyTerms w;
  work_energy(model, sa, sb, o.transition_time_s, ws.a, ws.b, o.work, &w);
  r.w.add(w);
  return r;
}

std::string energy_report_json(const EnergyReport& r) {
  nlohmann::json j;
  j["h_J"] = r.h_J;
  j["g_J"] = r.g_J;
  j["g_paper_J"] = r.g_J;  // the same value by the name that says whose it is
  j["terms"] = terms_json(r.terms);
  j["from"] = {{"file", r.from.file.string()}, {"frame", r.from.frame}};
  j["to"] = {{"file", r.to.file.string()}, {"frame", r.to.frame}};
  j["transition_time_s"] = r.transition_time_s;
  j["character"] = r.character;
  j["total_mass_kg"] = r.total_mass_kg;
  j["unit"] = {{"from", r.from_unit}, {"to", r.to_unit}};
  j["contacts"] = {{"from", r.from_contacts}, {"to", r.to_contacts}};
  j["residual"] = {{"work_J", r.residual_work_J}, {"impulse_J", r.residual_impulse_J}};
  j["w_J"] = r.w.total_J;
  j["w_parts"] = work_parts_json(r.w);
  j["cross_rig"] = r.cross_rig;
  if (r.cross_rig) j["compared_classes"] = r.compared_classes;
  return json_text(j);
}

std::string energy_report_text(const EnergyReport& r) {
  std::string s =
      fmt::format("{}:{} -> {}:{}  T = {} s  character {} ({:.1f} kg)  units {} / {}\n",
                  r.from.file.string(), r.from.frame, r.to.file.string(), r.to.frame,
                  r.transition_time_s, r.character, r.total_mass_kg, r.from_unit, r.to_unit);
  s += fmt::format(
      "h = {:.6g} J   g (g_paper) = {:.6g} J   (contacts {} / {}, root residual work {:.4g} J, "
      "impulse "
      "{:.4g} J)\n\n",
      r.h_J, r.g_J, r.from_contacts, r.to_contacts, r.residual_work_J, r.residual_impulse_J);
  s += work_line(r.w) + "\n\n";
  if (r.cross_rig) {
    s += "across rigs: the --to frame retargeted onto the --from skeleton; compared:";
    for (const auto& c : r.compared_classes) s += " " + c;
    s += "\n\n";
  }
  return s + terms_table(r.terms);
}

namespace {

// The motion's file read as the indexer reads it (Y up), at least 2 frames.
RawClip read_motion_clip(const std::filesystem::path& file) {
  RawClip raw = read_bvh_file(file);
  normalise_up_axis(raw, std::nullopt);
  if (raw.frame_count < 2)
    throw InputError(
        file.string(), 0,
        fmt::format("a motion needs at least 2 frames; the file has {}", raw.frame_count));
  return raw;
}

// --frames S-E checked against the file: S < E < frame count (the whole file without it).
std::pair<std::size_t, std::size_t> motion_frames(const MotionEnergyOptions& o,
                                                  std::size_t frame_count) {
  if (!o.frames) return {0, frame_count - 1};
  const auto [first, last] = *o.frames;
  if (first >= last)
    throw InputError(
        "--frames", 0,
        fmt::format("{}-{} holds no step: a motion's energy needs S < E", first, last));
  if (last >= frame_count)
    throw InputError("--frames", 0,
                     fmt::format("frame {} out of range: {} has {} frames (0-based)", last,
                                 o.file.string(), frame_count));
  return {first, last};
}

// Adds the step's terms to the report's sums (per term, in energy_term_names order).
void add_step_terms(const FullEnergyTerms& t, const std::vector<NamedEnergyTerm>& names,
                    MotionEnergyReport& r) {
  r.h_J += t.h.total();
  for (std::size_t j = 0; j < t.adjacent_work_J.size(); ++j) {
    r.adjacent_work_J += t.adjacent_work_J[j];
    r.contact_work_J += t.contact_work_J[j];
    r.joint_work_J += t.joint_work_J[j];
  }
  r.residual_work_J += t.residual_work_J;
  r.residual_impulse_J += t.residual_impulse_J;
  for (std::size_t i = 0; i < names.size(); ++i) {
    const auto j = static_cast<std::size_t>(names[i].joint);
    r.terms[i].h_J += names[i].is_joint ? t.h.joint_J[j] : t.h.segment_J[j];
    r.terms[i].g_J += names[i].is_joint ? t.g.joint_J[j] : t.g.segment_J[j];
  }
}

// The steps S -> S+1 .. E-1 -> E: g with its parts and terms, and the frames
// without contact (one inverse dynamics per frame, reused by both its steps).
void sum_motion_steps(const LoadedClip& c, double dt, const WorkEnergyParams& work,
                      MotionEnergyReport& r) {
  const std::vector<NamedEnergyTerm> names = energy_term_names(c.model);
  for (const NamedEnergyTerm& n : names) r.terms.push_back({n.name, n.is_joint, 0.0, 0.0});
  NewtonEulerData id[2];
  NewtonEulerWorkspace ws;
  FullEnergyTerms terms;
  WorkEnergyTerms w_terms;
  inverse_dynamics(c.model, c.dynamics.state(r.first_frame), id[0]);
  r.no_contact_frames = id[0].contact_count == 0 ? 1 : 0;
  for (std::size_t f = r.first_frame; f < r.last_frame; ++f) {
    const NewtonEulerData& a = id[(f - r.first_frame) % 2];
    NewtonEulerData& b = id[(f - r.first_frame + 1) % 2];
    inverse_dynamics(c.model, c.dynamics.state(f + 1), b);
    if (b.contact_count == 0) ++r.no_contact_frames;
    const double g =
        full_energy(c.model, c.dynamics.state(f), c.dynamics.state(f + 1), dt, a, b, ws, &terms);
    r.step_g_J.push_back(g);
    r.g_J += g;
    add_step_terms(terms, names, r);
    r.step_w_J.push_back(work_energy(c.model, c.dynamics.state(f), c.dynamics.state(f + 1), dt, a,
                                     b, work, &w_terms));
    r.w.add(w_terms);
  }
}

// The largest local angular speed of a segment joint other than a body root
// (the pelvis's local rotation is the body's turn, not a joint's).
void peak_joint_speed(const LoadedClip& c, double dt, MotionEnergyReport& r) {
  const std::size_t n = c.skeleton.joint_count();
  for (const int joint : c.model.segments) {
    const auto j = static_cast<std::size_t>(joint);
    if (c.model.is_body_root[j]) continue;
    for (std::size_t f = r.first_frame; f < r.last_frame; ++f) {
      const Eigen::Quaterniond step =
          c.local_rotations[(f + 1) * n + j] * c.local_rotations[f * n + j].conjugate();
      const double speed = rotation_vector(step).norm() / dt;
      if (speed > r.peak_angular_speed_radps) {
        r.peak_angular_speed_radps = speed;
        r.peak_joint = c.model.names[j];
      }
    }
  }
}

// Steps in which a foot or toe joint skates: its origin below
// kSkatingHeightM above the ground in both frames, moving horizontally
// faster than kSkatingSpeedMps (the synthesis measures' rule).
void skating_steps(const LoadedClip& c, double dt, MotionEnergyReport& r) {
  const std::vector<int> feet = foot_joints(classify_joints(c.skeleton), c.model);
  const double ground = c.model.params.ground_height_m;
  for (std::size_t f = r.first_frame; f < r.last_frame; ++f) {
    const StateView a = c.dynamics.state(f), b = c.dynamics.state(f + 1);
    for (const int jj : feet) {
      const auto j = static_cast<std::size_t>(jj);
      if (low_foot_speed(a.joint_positions_m[j], b.joint_positions_m[j], dt, ground) >
          kSkatingSpeedMps) {
        ++r.skating_steps;
        break;
      }
    }
  }
}

}  // namespace

MotionEnergyReport run_motion_energy_command(const MotionEnergyOptions& o) {
  check_work_params(o.work);
  Character character;
  if (!o.character.empty()) character = read_character_file(o.character);
  const RawClip raw = read_motion_clip(o.file);
  const auto [first, last] = motion_frames(o, raw.frame_count);
  if (!(raw.frame_time_s > 0.0) || !std::isfinite(raw.frame_time_s))
    throw InputError(o.file.string(), 0, "the frame time must be a positive number of seconds");
  const LengthUnit unit = o.unit ? *o.unit : detect_unit(raw);
  const LoadedClip c = load_clip({o.file, 0}, raw, character, unit);
  MotionEnergyReport r;
  r.file = o.file;
  r.first_frame = first;
  r.last_frame = last;
  r.frame_time_s = raw.frame_time_s;
  r.character = character.name;
  r.unit = c.unit;
  r.total_mass_kg = c.model.total_mass_kg;
  sum_motion_steps(c, raw.frame_time_s, o.work, r);
  peak_joint_speed(c, raw.frame_time_s, r);
  skating_steps(c, raw.frame_time_s, r);
  return r;
}

std::string motion_energy_report_json(const MotionEnergyReport& r) {
  nlohmann::json j;
  const std::size_t frames = r.last_frame - r.first_frame + 1;
  j["motion"] = {{"file", r.file.string()},
                 {"first_frame", r.first_frame},
                 {"last_frame", r.last_frame},
                 {"steps", r.step_g_J.size()},
                 {"frame_time_s", r.frame_time_s}};
  j["h_J"] = r.h_J;
  j["g_J"] = r.g_J;
  j["g_paper_J"] = r.g_J;  // the same value by the name that says whose it is
  j["parts"] = {{"h_J", r.h_J},
                {"adjacent_work_J", r.adjacent_work_J},
                {"contact_work_J", r.contact_work_J},
                {"joint_work_J", r.joint_work_J},
                {"residual_work_J", r.residual_work_J},
                {"residual_impulse_J", r.residual_impulse_J}};
  j["w_J"] = r.w.total_J;
  j["w_parts"] = work_parts_json(r.w);
  j["terms"] = terms_json(r.terms);
  j["step_g_J"] = r.step_g_J;
  j["step_w_J"] = r.step_w_J;
  j["no_contact_frames"] = r.no_contact_frames;
  j["no_contact_ratio"] = static_cast<double>(r.no_contact_frames) / static_cast<double>(frames);
  j["peak_angular_speed_radps"] = r.peak_angular_speed_radps;
  j["peak_joint"] = r.peak_joint;
  j["skating_steps"] = r.skating_steps;
  j["skating_ratio"] =
      static_cast<double>(r.skating_steps) / static_cast<double>(r.step_g_J.size());
  j["character"] = r.character;
  j["total_mass_kg"] = r.total_mass_kg;
  j["unit"] = r.unit;
  return json_text(j);
}

std::string motion_energy_report_text(const MotionEnergyReport& r) {
  const std::size_t frames = r.last_frame - r.first_frame + 1;
  std::string s =
      fmt::format("{} frames {}-{} ({} steps of {} s)  character {} ({:.1f} kg)  unit {}\n",
                  r.file.string(), r.first_frame, r.last_frame, r.step_g_J.size(), r.frame_time_s,
                  r.character, r.total_mass_kg, r.unit);
  s += fmt::format(
      "h = {:.6g} J   g (g_paper) = {:.6g} J = h + adjacent {:.4g} + contact {:.4g} + joint {:.4g} "
      "+ "
      "residual work {:.4g} + residual impulse {:.4g}\n",
      r.h_J, r.g_J, r.adjacent_work_J, r.contact_work_J, r.joint_work_J, r.residual_work_J,
      r.residual_impulse_J);
  s += work_line(r.w) + "\n";
  s += fmt::format(
      "frames without contact {} of {}   peak joint angular speed {:.3g} rad/s ({})   skating "
      "steps {} of {}\n\n",
      r.no_contact_frames, frames, r.peak_angular_speed_radps, r.peak_joint, r.skating_steps,
      r.step_g_J.size());
  return s + terms_table(r.terms);
}

}  // namespace mocap
