#include "mocap/search/query.hpp"
#include "mocap/common/util/frame_range.hpp"
#include "mocap/common/util/input_limits.hpp"
#include "mocap/common/util/json_text.hpp"

#include <fnmatch.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <numbers>
#include <vector>

#include "mocap/common/dynamics/kinematics.hpp"
#include "mocap/common/util/edit_distance.hpp"
#include "mocap/common/util/error.hpp"

namespace mocap {

namespace {

using json = nlohmann::json;

// Error context: the query's source and line plus the field path being read.
struct Ctx {
  const std::string& source;
  std::size_t line;
  [[noreturn]] void fail(const std::string& path, const std::string& what) const {
    throw InputError(source, line, path + ": " + what);
  }
};

std::string fmt_range(double v, double lo, double hi) {
  return "out of range: " + json_text(json(v)) + " degrees; expected " + json_text(json(lo)) +
         " to " + json_text(json(hi));
}

std::string type_name(const json& v) {
  return v.type_name();
}

// A finite number of magnitude at most max_abs (docs/cli.md "Value
// ranges": finite values beyond a field's range are not a pose or a time).
double number(const Ctx& c, const json& v, const std::string& path, double max_abs = 1e6) {
  if (!v.is_number()) c.fail(path, "expected a number, got " + type_name(v));
  const double d = v.get<double>();
  if (!std::isfinite(d)) c.fail(path, "expected a finite number");
  if (std::abs(d) > max_abs)
    c.fail(path, "out of range: " + json_text(v) + "; |value| must be at most " +
                     json_text(json(max_abs)));
  return d;
}

std::vector<std::string> string_list(const Ctx& c, const json& v, const std::string& path) {
  std::vector<std::string> out;
  if (v.is_string()) {
    out.push_back(v.get<std::string>());
    return out;
  }
  if (!v.is_array()) c.fail(path, "expected a string or a list of strings, got " + type_name(v));
  for (std::size_t i = 0; i < v.size(); ++i) {
    if (!v[i].is_string())
      c.fail(path + "[" + std::to_string(i) + "]", "expected a string, got " + type_name(v[i]));
    out.push_back(v[i].get<std::string>());
  }
  return out;
}

// "did you mean X? " for the allowed name nearest `key` within an edit
// distance of 2, letters compared without case (the first of equals), else "".
std::string did_you_mean(const std::string& key, std::initializer_list<const char*> allowed) {
  const char* best = nullptr;
  std::size_t best_distance = 3;
  const std::string lower_key = ascii_lower(key);
  for (const char* a : allowed) {
    const std::size_t d = edit_distance(lower_key, ascii_lower(a));
    if (d < best_distance) best = a, best_distance = d;
  }
  return best ? std::string("did you mean \"") + best + "\"? " : "";
}

void check_keys(const Ctx& c, const json& obj, const std::string& path,
                std::initializer_list<const char*> allowed) {
  for (auto it = obj.begin(); it != obj.end(); ++it) {
    bool ok = false;
    for (const char* a : allowed) ok = ok || it.key() == a;
    if (!ok) {
      std::string list;
      for (const char* a : allowed) list += std::string(list.empty() ? "" : ", ") + a;
      c.fail(
          path.empty() ? it.key() : path + "." + it.key(),
          "unknown field (" + did_you_mean(it.key(), allowed) + "expected one of: " + list + ")");
    }
  }
}

// "weight": a multiplier > 0 (docs/queries.md "Weights").
std::optional<double> weight(const Ctx& c, const json& v, const std::string& path) {
  if (!v.is_object() || !v.contains("weight")) return std::nullopt;
  const double w = number(c, v["weight"], path + ".weight");
  if (!(w > 0.0)) c.fail(path + ".weight", "must be > 0");
  return w;
}

// A tolerance >= 0 of `key` (degrees or metres), 0 when absent.
double tolerance(const Ctx& c, const json& v, const std::string& path, const char* key,
                 double max) {
  if (!v.contains(key)) return 0.0;
  const double t = number(c, v[key], path + "." + key, max);
  if (t < 0.0) c.fail(path + "." + key, "must be >= 0");
  return t;
}

Eigen::Vector3d vector3(const Ctx& c, const json& v, const std::string& path, double max_abs,
                        const char* what) {
  if (!v.is_array() || v.size() != 3) c.fail(path, std::string("expected [x, y, z]: ") + what);
  return {number(c, v[0], path + "[0]", max_abs), number(c, v[1], path + "[1]", max_abs),
          number(c, v[2], path + "[2]", max_abs)};
}

JointRotationSpec joint_entry(const Ctx& c, const std::string& name, const json& v,
                              const std::string& path);

Eigen::Quaterniond joint_rotation(const Ctx& c, const json& v, const std::string& path) {
  const bool has_euler = v.contains("euler_deg"), has_quat = v.contains("quat");
  if (has_euler == has_quat)
    c.fail(path, "give exactly one of euler_deg (with order), quat or direction");
  if (has_quat) {
    if (v.contains("order")) c.fail(path + ".order", "only with euler_deg");
    const json& q = v["quat"];
    if (!q.is_array() || q.size() != 4) c.fail(path + ".quat", "expected 4 numbers [w, x, y, z]");
    Eigen::Quaterniond out(number(c, q[0], path + ".quat[0]"), number(c, q[1], path + ".quat[1]"),
                           number(c, q[2], path + ".quat[2]"), number(c, q[3], path + ".quat[3]"));
    if (out.norm() < 1e-9) c.fail(path + ".quat", "must not be zero");
    return out.normalized();
  }
  const json& e = v["euler_deg"];
  if (!e.is_array() || e.size() != 3) c.fail(path + ".euler_deg", "expected 3 numbers (degrees)");
  if (!v.contains("order") || !v["order"].is_string())
    c.fail(path + ".order", "expected a string such as \"ZXY\" (the order the angles apply in)");
  const std::string order = v["order"].get<std::string>();
  const auto axes = parse_euler_order(order);
  if (!axes)
    c.fail(path + ".order", "expected 3 distinct letters of X, Y, Z, got \"" + order + "\"");
  const std::array<double, 3> deg{number(c, e[0], path + ".euler_deg[0]"),
                                  number(c, e[1], path + ".euler_deg[1]"),
                                  number(c, e[2], path + ".euler_deg[2]")};
  return euler_to_quaternion(*axes, deg);
}

JointRotationSpec joint_entry(const Ctx& c, const std::string& name, const json& v,
                              const std::string& path) {
  if (!v.is_object())
    c.fail(path,
           "expected {\"euler_deg\": [a, b, c], \"order\": \"ZXY\"}, {\"quat\": [w, x, y, z]} "
           "or {\"direction\": [x, y, z]}");
  check_keys(c, v, path, {"euler_deg", "order", "quat", "direction", "tolerance_deg", "weight"});
  JointRotationSpec out;
  out.name = name;
  out.weight = weight(c, v, path);
  if (v.contains("direction")) {
    if (v.contains("euler_deg") || v.contains("quat") || v.contains("order"))
      c.fail(path, "give a direction or a rotation (euler_deg, quat), not both");
    const Eigen::Vector3d d = vector3(c, v["direction"], path + ".direction", 1e6,
                                      "a direction in the body frame (+x left, +y up, +z forward)");
    if (d.norm() < 1e-9) c.fail(path + ".direction", "must not be zero");
    out.direction = d.normalized();
    out.tolerance_deg = tolerance(c, v, path, "tolerance_deg", 180.0);
    return out;
  }
  if (v.contains("tolerance_deg")) c.fail(path + ".tolerance_deg", "only with direction");
  out.rotation = joint_rotation(c, v, path);
  return out;
}

// The anatomical angles a query frame may give, with their ranges (degrees).
struct AngleRange {
  const char* name;
  double lo, hi;
};
constexpr AngleRange kAngles[] = {
    {"trunk_flexion", -180, 180},         {"left_hip_flexion", -180, 180},
    {"right_hip_flexion", -180, 180},     {"left_knee_flexion", 0, 180},
    {"right_knee_flexion", 0, 180},       {"left_elbow_flexion", 0, 180},
    {"right_elbow_flexion", 0, 180},      {"left_shoulder_elevation", 0, 180},
    {"right_shoulder_elevation", 0, 180},
};

AngleSpec angle_entry(const Ctx& c, const std::string& name, const json& v,
                      const std::string& path) {
  const AngleRange* range = nullptr;
  for (const AngleRange& r : kAngles)
    if (name == r.name) range = &r;
  if (range == nullptr) {
    std::string list;
    for (const AngleRange& r : kAngles) list += std::string(list.empty() ? "" : ", ") + r.name;
    c.fail(path, "unknown angle \"" + name + "\" (known: " + list + ")");
  }
  AngleSpec out;
  out.name = name;
  if (v.is_number()) {
    out.deg = number(c, v, path, 360.0);
  } else {
    if (!v.is_object())
      c.fail(path, "expected degrees or {\"deg\": d, \"tolerance_deg\": t, \"weight\": w}");
    check_keys(c, v, path, {"deg", "tolerance_deg", "weight"});
    if (!v.contains("deg")) c.fail(path + ".deg", "required: the angle in degrees");
    out.deg = number(c, v["deg"], path + ".deg", 360.0);
    out.tolerance_deg = tolerance(c, v, path, "tolerance_deg", 180.0);
    out.weight = weight(c, v, path);
  }
  if (out.deg < range->lo || out.deg > range->hi)
    c.fail(path, fmt_range(out.deg, range->lo, range->hi));
  return out;
}

EffectorSpec effector_entry(const Ctx& c, const std::string& name, const json& v,
                            const std::string& path) {
  if (!v.is_object())
    c.fail(path, "expected {\"position_m\": [x, y, z], \"tolerance_m\": t, \"weight\": w}");
  check_keys(c, v, path, {"position_m", "tolerance_m", "weight"});
  if (!v.contains("position_m"))
    c.fail(path + ".position_m", "required: the target in the body frame, metres");
  EffectorSpec out;
  out.name = name;
  out.position_m = vector3(c, v["position_m"], path + ".position_m", 100.0,
                           "metres in the body frame (+x left, +y up, +z forward)");
  out.tolerance_m = tolerance(c, v, path, "tolerance_m", 100.0);
  out.weight = weight(c, v, path);
  return out;
}

std::filesystem::path resolve(const std::filesystem::path& base, const std::string& p) {
  std::filesystem::path out(p);
  return out.is_relative() ? base / out : out;
}

// "context": {"before": K, "after": K, "weight": W} of a file frame.
void context_entry(const Ctx& c, const json& v, const std::string& path, QueryFrameSpec& f) {
  if (!v.is_object() || v.empty())
    c.fail(path, "expected an object {\"before\": 10, \"after\": 0, \"weight\": 1}");
  check_keys(c, v, path, {"before", "after", "weight"});
  if (!f.only.empty())
    c.fail(path, "only with a whole frame (no \"only\"): the context compares whole bodies");
  for (const char* key : {"before", "after"}) {
    if (!v.contains(key)) continue;
    const json& k = v[key];
    if (!k.is_number_integer() || k.get<long long>() < 0 ||
        k.get<long long>() > static_cast<long long>(kMaxContextFrames))
      c.fail(path + "." + key, "expected a number of frames from 0 to " +
                                   std::to_string(kMaxContextFrames) + ", got " + json_text(k));
    (std::string(key) == "before" ? f.context_before : f.context_after) =
        static_cast<std::size_t>(k.get<long long>());
  }
  if (v.contains("weight")) f.context_weight = *weight(c, v, path);
}

QueryFrameSpec query_frame(const Ctx& c, const json& v, const std::string& path,
                           const std::filesystem::path& base_dir) {
  if (!v.is_object()) c.fail(path, "expected an object, got " + type_name(v));
  check_keys(c, v, path,
             {"root_position", "root_heading_deg", "joints", "angles", "effectors", "weight", "bvh",
              "amc", "asf", "amc_fps", "frame", "only", "time_s", "context"});
  QueryFrameSpec f;
  if (v.contains("weight")) f.weight = *weight(c, v, path);
  for (const char* key : {"angles", "effectors"}) {
    if (!v.contains(key)) continue;
    const json& o = v[key];
    const std::string at = path + "." + key;
    if (!o.is_object() || o.empty())
      c.fail(at, std::string("expected a non-empty object {\"") +
                     (std::string(key) == "angles" ? "trunk_flexion\": 40" : "RightHand\": {...}") +
                     ", ...}");
    for (auto it = o.begin(); it != o.end(); ++it) {
      if (it.key().empty()) c.fail(at, "empty name");
      if (std::string(key) == "angles")
        f.angles.push_back(angle_entry(c, it.key(), it.value(), at + "." + it.key()));
      else
        f.effectors.push_back(effector_entry(c, it.key(), it.value(), at + "." + it.key()));
    }
  }
  if (v.contains("time_s")) {
    const double t = number(c, v["time_s"], path + ".time_s", 3600.0);
    if (t < 0.0) c.fail(path + ".time_s", "must be >= 0 seconds");
    f.time_s = t;
  }
  if (v.contains("root_position")) {
    const json& p = v["root_position"];
    if (!p.is_array() || p.size() != 3)
      c.fail(path + ".root_position", "expected [x, y, z] in metres (null = not given)");
    for (std::size_t a = 0; a < 3; ++a)
      if (!p[a].is_null())
        f.root_position_m[a] =
            number(c, p[a], path + ".root_position[" + std::to_string(a) + "]", 1e4);
  }
  if (v.contains("root_heading_deg"))
    f.root_heading_deg = number(c, v["root_heading_deg"], path + ".root_heading_deg");
  if (v.contains("joints")) {
    const json& js = v["joints"];
    if (!js.is_object()) c.fail(path + ".joints", "expected an object {\"JointName\": {...}}");
    for (auto it = js.begin(); it != js.end(); ++it) {
      if (it.key().empty()) c.fail(path + ".joints", "empty joint name");
      // An invalid value waits until the name is known (joint_value_error).
      try {
        f.joints.push_back(joint_entry(c, it.key(), it.value(), path + ".joints." + it.key()));
      } catch (const InputError& e) {
        JointRotationSpec kept;
        kept.name = it.key();
        f.joints.push_back(std::move(kept));
        if (!f.joint_value_error) f.joint_value_error = e;
      }
    }
  }
  const bool has_amc = v.contains("amc");
  if (has_amc && v.contains("bvh")) c.fail(path, "give bvh or amc, not both");
  if (!has_amc && (v.contains("asf") || v.contains("amc_fps")))
    c.fail(path + (v.contains("asf") ? ".asf" : ".amc_fps"), "only with amc");
  const bool has_bvh = v.contains("bvh") || has_amc;
  const std::string file_key = has_amc ? "amc" : "bvh";
  if (has_bvh) {
    if (!v[file_key].is_string() || v[file_key].get<std::string>().empty())
      c.fail(path + "." + file_key,
             has_amc ? "expected an AMC file path" : "expected a BVH file path");
    if (has_amc) {
      if (!v.contains("asf") || !v["asf"].is_string() || v["asf"].get<std::string>().empty())
        c.fail(path + ".asf", "required with amc: the take's ASF skeleton file");
      f.asf = resolve(base_dir, v["asf"].get<std::string>());
      if (v.contains("amc_fps")) {
        f.amc_fps = number(c, v["amc_fps"], path + ".amc_fps", 1000.0);
        if (!(f.amc_fps > 0.0)) c.fail(path + ".amc_fps", "must be > 0 frames per second");
      }
    }
    if (!v.contains("frame"))
      c.fail(path + ".frame", "required with " + file_key + " (0-based frame number)");
    const json& fr = v["frame"];
    if (!fr.is_number_integer() || fr.get<long long>() < 0)
      c.fail(path + ".frame", "expected a non-negative integer");
    f.bvh = resolve(base_dir, v[file_key].get<std::string>());
    f.bvh_frame = static_cast<std::size_t>(fr.get<long long>());
    if (v.contains("only")) {
      f.only = string_list(c, v["only"], path + ".only");
      if (f.only.empty())
        c.fail(path + ".only", "must not be empty (leave it out to take every DOF)");
    }
    if (v.contains("root_position") || v.contains("root_heading_deg") || v.contains("joints"))
      c.fail(path, "bvh frames take their values from the file: use \"only\" to keep some DOFs");
    if ((v.contains("angles") || v.contains("effectors")) && f.only.empty())
      c.fail(path + (v.contains("angles") ? ".angles" : ".effectors"),
             "a whole bvh frame gives every joint: with angles or effectors, use \"only\" to keep "
             "some DOFs of the file");
    if (v.contains("context")) context_entry(c, v["context"], path + ".context", f);
  } else {
    if (v.contains("frame")) c.fail(path + ".frame", "only with bvh");
    if (v.contains("only")) c.fail(path + ".only", "only with bvh");
    if (v.contains("context"))
      c.fail(path + ".context",
             "only with a whole bvh or amc frame: the context is the file's frames around it");
  }
  if (f.empty())
    c.fail(path,
           "gives nothing: expected root_position, root_heading_deg, joints, angles, effectors or "
           "bvh");
  return f;
}

bool glob_match(const std::string& pattern, const std::string& name) {
  return fnmatch(pattern.c_str(), name.c_str(), 0) == 0;
}

}  // namespace

bool QueryFrameSpec::empty() const {
  return !bvh && joints.empty() && angles.empty() && effectors.empty() && !root_heading_deg &&
         !root_position_m[0] && !root_position_m[1] && !root_position_m[2];
}

bool QueryFrameSpec::constrained() const {
  if (!angles.empty() || !effectors.empty()) return true;
  for (const JointRotationSpec& j : joints)
    if (j.direction || j.weight) return true;
  return false;
}

bool QueryFilter::accepts(const std::string& file_name, const std::string& content_label,
                          const std::string& style_label) const {
  auto in = [](const std::vector<std::string>& list, const std::string& v) {
    for (const auto& x : list)
      if (x == v) return true;
    return false;
  };
  if (!content.empty() && !in(content, content_label)) return false;
  if (!style.empty() && !in(style, style_label)) return false;
  if (!clips.empty()) {
    bool any = false;
    for (const auto& g : clips) any = any || glob_match(g, file_name);
    if (!any) return false;
  }
  for (const auto& g : exclude)
    if (glob_match(g, file_name)) return false;
  return true;
}

std::optional<std::array<std::uint8_t, 3>> parse_euler_order(const std::string& order) {
  if (order.size() != 3) return std::nullopt;
  std::array<std::uint8_t, 3> axes{};
  for (std::size_t i = 0; i < 3; ++i) {
    const char ch = static_cast<char>(std::toupper(static_cast<unsigned char>(order[i])));
    if (ch < 'X' || ch > 'Z') return std::nullopt;
    axes[i] = static_cast<std::uint8_t>(ch - 'X');
  }
  if (axes[0] == axes[1] || axes[1] == axes[2] || axes[0] == axes[2]) return std::nullopt;
  return axes;
}

const char* placement_name(FramePlacement p) {
  switch (p) {
    case FramePlacement::world:
      return "world";
    case FramePlacement::position:
      return "position";
    case FramePlacement::relative:
      return "relative";
  }
  return "?";
}

const char* met_policy_name(MetPolicy p) {
  switch (p) {
    case MetPolicy::any:
      return "any";
    case MetPolicy::first:
      return "first";
    case MetPolicy::only:
      return "only";
  }
  return "first";
}

namespace {

MetPolicy met_policy(const Ctx& c, const json& v) {
  for (const MetPolicy p : {MetPolicy::any, MetPolicy::first, MetPolicy::only})
    if (v.is_string() && v.get<std::string>() == met_policy_name(p)) return p;
  c.fail("met", "expected \"first\", \"only\" or \"any\", got " + json_text(v));
}

// "style": {"label": L | "like": {"bvh": F, "frames": "S-E"}, "weight": W}.
QueryStyle query_style(const Ctx& c, const json& v, const std::filesystem::path& base_dir) {
  if (!v.is_object()) c.fail("style", "expected an object, got " + type_name(v));
  check_keys(c, v, "style", {"label", "like", "weight"});
  QueryStyle s;
  if (v.contains("label") == v.contains("like"))
    c.fail("style", "give either \"label\" (a style of the model) or \"like\" (a file's frames)");
  if (v.contains("label")) {
    if (!v["label"].is_string() || v["label"].get<std::string>().empty())
      c.fail("style.label", "expected a style name");
    s.label = v["label"].get<std::string>();
  } else {
    const json& like = v["like"];
    if (!like.is_object()) c.fail("style.like", "expected {\"bvh\": FILE, \"frames\": \"S-E\"}");
    check_keys(c, like, "style.like", {"bvh", "frames"});
    if (!like.contains("bvh") || !like["bvh"].is_string() || like["bvh"].get<std::string>().empty())
      c.fail("style.like.bvh", "expected a BVH file path");
    s.like_bvh = resolve(base_dir, like["bvh"].get<std::string>());
    if (like.contains("frames")) {
      if (!like["frames"].is_string())
        c.fail("style.like.frames",
               "expected \"S-E\" (0-based, S <= E), got " + json_text(like["frames"]));
      FrameRange r;
      try {
        r = parse_frame_range(like["frames"].get<std::string>(), "style.like.frames");
      } catch (const InputError& e) {
        c.fail("style.like.frames", e.detail());
      }
      s.like_first = r.first;
      s.like_last = r.last;
      s.like_whole = false;
    }
  }
  if (v.contains("weight")) {
    s.weight = number(c, v["weight"], "style.weight");
    if (!(s.weight > 0.0)) c.fail("style.weight", "must be > 0 (joules per nat)");
  }
  return s;
}

}  // namespace

Query parse_query(const json& j, const std::string& source, std::size_t line,
                  const std::filesystem::path& base_dir, const std::string& default_id) {
  const Ctx c{source, line};
  if (!j.is_object()) c.fail("query", "expected a JSON object, got " + type_name(j));
  check_keys(c, j, "",
             {"id", "frames", "relative", "character", "transition_time", "top", "path_weight",
              "filter", "min_length_s", "max_length_s", "met", "style", "synth_style"});
  Query q;
  q.id = default_id;
  if (j.contains("id")) {
    if (j["id"].is_string())
      q.id = j["id"].get<std::string>();
    else if (j["id"].is_number_integer())
      q.id = std::to_string(j["id"].get<long long>());
    else
      c.fail("id", "expected a string or an integer, got " + type_name(j["id"]));
  }
  if (!j.contains("frames")) c.fail("frames", "required: a list of at least 2 query frames");
  const json& frames = j["frames"];
  if (!frames.is_array()) c.fail("frames", "expected a list of query frames");
  if (frames.size() < 2)
    c.fail("frames", "at least 2 query frames are needed, got " + std::to_string(frames.size()));
  if (const std::size_t most = input_limits().query_frames; frames.size() > most)
    c.fail("frames", "at most " + std::to_string(most) +
                         " query frames (--max-query-frames), got " +
                         std::to_string(frames.size()));
  for (std::size_t i = 0; i < frames.size(); ++i)
    q.frames.push_back(query_frame(c, frames[i], "frames[" + std::to_string(i) + "]", base_dir));
  // Key-pose times: all frames or none, the first at 0, strictly increasing
  // by at least a millisecond.
  for (std::size_t i = 0; i < q.frames.size(); ++i) {
    const std::string at = "frames[" + std::to_string(i) + "].time_s";
    if (q.frames[i].time_s.has_value() != q.frames[0].time_s.has_value())
      c.fail(at, "give time_s on every query frame or on none");
    if (!q.frames[i].time_s) continue;
    if (i == 0 && *q.frames[0].time_s != 0.0)
      c.fail(at, "the first key pose is at 0 seconds, got " + json_text(frames[0]["time_s"]));
    if (i > 0 && !(*q.frames[i].time_s >= *q.frames[i - 1].time_s + 1e-3))
      c.fail(at, "must exceed the previous frame's time_s by at least 0.001 s");
  }
  if (j.contains("relative")) {
    const json& r = j["relative"];
    if (r.is_boolean())
      q.placement = r.get<bool>() ? FramePlacement::relative : FramePlacement::world;
    else if (r.is_string() && r.get<std::string>() == "position")
      q.placement = FramePlacement::position;
    else
      c.fail("relative", "expected true, false or \"position\", got " + json_text(r));
  }
  for (const char* key : {"min_length_s", "max_length_s"})
    if (j.contains(key)) {
      const double v = number(c, j[key], key, 3600.0);
      if (v <= 0.0) c.fail(key, "must be > 0 seconds");
      (std::string(key) == "min_length_s" ? q.min_length_s : q.max_length_s) = v;
    }
  if (q.min_length_s && q.max_length_s && *q.min_length_s > *q.max_length_s)
    c.fail("min_length_s", "must not exceed max_length_s");
  if (j.contains("character")) {
    if (!j["character"].is_string() || j["character"].get<std::string>().empty())
      c.fail("character", "expected a character JSON file path");
    q.character = resolve(base_dir, j["character"].get<std::string>());
  }
  if (j.contains("transition_time")) {
    q.transition_time_s = number(c, j["transition_time"], "transition_time", 60.0);
    if (q.transition_time_s < 1e-3) c.fail("transition_time", "must be 0.001 to 60 seconds");
  }
  if (j.contains("top")) {
    const json& t = j["top"];
    if (!t.is_number_integer())
      c.fail("top", "expected an integer >= 1, got " +
                        (t.is_number() ? "the number " + json_text(t) : type_name(t)));
    if (t.get<long long>() < 1) c.fail("top", "expected an integer >= 1, got " + json_text(t));
    q.top = static_cast<std::size_t>(t.get<long long>());
  }
  if (j.contains("path_weight")) {
    q.path_weight = number(c, j["path_weight"], "path_weight");
    if (q.path_weight < 0.0) c.fail("path_weight", "must be >= 0");
  }
  if (j.contains("met")) q.met = met_policy(c, j["met"]);
  if (j.contains("filter")) {
    const json& f = j["filter"];
    if (!f.is_object()) c.fail("filter", "expected an object, got " + type_name(f));
    check_keys(c, f, "filter", {"content", "style", "clips", "exclude"});
    if (f.contains("content")) q.filter.content = string_list(c, f["content"], "filter.content");
    if (f.contains("style")) q.filter.style = string_list(c, f["style"], "filter.style");
    if (f.contains("clips")) q.filter.clips = string_list(c, f["clips"], "filter.clips");
    if (f.contains("exclude")) q.filter.exclude = string_list(c, f["exclude"], "filter.exclude");
  }
  if (j.contains("style")) q.style = query_style(c, j["style"], base_dir);
  if (j.contains("synth_style")) {
    if (!j["synth_style"].is_string() || j["synth_style"].get<std::string>().empty())
      c.fail("synth_style", "expected a style name (of the model given with --style-model)");
    q.synth_style = j["synth_style"].get<std::string>();
  }
  return q;
}

Query parse_query_text(const std::string& text, const std::string& source, std::size_t line,
                       const std::filesystem::path& base_dir, const std::string& default_id) {
  json j;
  try {
    j = json::parse(text);
  } catch (const json::exception& e) {
    throw InputError(source, line, std::string("invalid JSON: ") + e.what());
  }
  return parse_query(j, source, line, base_dir, default_id);
}

}  // namespace mocap
