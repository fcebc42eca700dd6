// Checks of a parsed query against what it runs on (query_validation.hpp).
#include "mocap/search/query_validation.hpp"

#include <fmt/format.h>

#include <algorithm>

#include "mocap/common/body/joint_classes.hpp"
#include "mocap/common/util/edit_distance.hpp"
#include "mocap/common/util/error.hpp"

namespace mocap {

namespace {

[[noreturn]] void fail(const Query& q, const std::string& path, const std::string& what) {
  throw InputError("query " + q.id, 0, path + ": " + what);
}

std::string joined(const std::vector<std::string>& names) {
  std::string out;
  for (const auto& n : names) out += (out.empty() ? "" : ", ") + n;
  return out;
}

}  // namespace

void add_label_values(LabelValues& values, const Index& index) {
  const std::vector<std::string>& keys = index.label_keys();
  for (const IndexClip& c : index.clips())
    for (std::size_t k = 0; k < keys.size() && k < c.labels.size(); ++k)
      if (!c.labels[k].empty()) values[keys[k]].insert(c.labels[k]);
}

LabelValues label_values(const Index& index) {
  LabelValues out;
  add_label_values(out, index);
  return out;
}

void check_filter_labels(const Query& q, const LabelValues& values, const std::string& where) {
  const std::pair<const char*, const std::vector<std::string>*> lists[] = {
      {"content", &q.filter.content}, {"style", &q.filter.style}};
  for (const auto& [key, list] : lists) {
    const auto it = values.find(key);
    for (const std::string& v : *list) {
      if (it != values.end() && it->second.count(v)) continue;
      const std::string path = std::string("filter.") + key;
      if (it == values.end())
        fail(q, path, fmt::format("unknown value \"{}\"; {} has no {} labels", v, where, key));
      fail(q, path,
           fmt::format("unknown value \"{}\"; {} has: {}", v, where,
                       joined({it->second.begin(), it->second.end()})));
    }
  }
}

int resolve_only_joint(const Query& q, std::size_t i, std::size_t k, const Skeleton& file_skeleton,
                       const Skeleton& index_skeleton, const std::vector<int>& file_joints) {
  const QueryFrameSpec& spec = q.frames[i];
  const std::string& name = spec.only[k];
  const std::string path = fmt::format("frames[{}].only[{}]", i, k);
  // The file whose skeleton the frame is read on: the BVH, or an AMC take's ASF.
  const std::string file = spec.asf   ? spec.asf->string()
                           : spec.bvh ? spec.bvh->string()
                                      : std::string("the file");
  const int f = find_joint_by_alias(file_skeleton, name);
  if (f < 0) {
    std::vector<std::string> valid(std::begin(kOnlyRootFields), std::end(kOnlyRootFields));
    valid.insert(valid.end(), file_skeleton.names.begin(), file_skeleton.names.end());
    fail(q, path,
         fmt::format("unknown name \"{}\": neither a root field nor a joint of {} ({}valid: {}; "
                     "canonical joint names such as RightUpperArm, LeftForeArm, Hips also work)",
                     name, file, joint_did_you_mean(file_skeleton, name), joined(valid)));
  }
  int j = find_joint_by_alias(index_skeleton, name);
  for (std::size_t c = 0; c < file_joints.size() && j < 0; ++c)
    if (file_joints[c] == f) j = static_cast<int>(c);
  if (j < 0)
    fail(q, path,
         fmt::format("joint \"{}\" of {} ({}) has no counterpart on the index skeleton (joints: "
                     "{})",
                     name, file, file_skeleton.names[static_cast<std::size_t>(f)],
                     joined(index_skeleton.names)));
  return j;
}

namespace {

// "left upper arm", "head": a joint's body part in words.
std::string part_words(const std::pair<SegmentClass, Side>& c) {
  std::string name = segment_class_name(c.first);
  std::replace(name.begin(), name.end(), '_', ' ');
  return is_sided(c.first) ? std::string(side_name(c.second)) + " " + name : name;
}

// The warning for `name` at `path` on skeleton `skel` (called `rig`), or "".
std::string name_warning(const std::string& path, const std::string& name, const Skeleton& skel,
                         const std::string& rig) {
  const int named = skel.find(name);
  const int read = find_joint_by_alias(skel, name);
  if (named < 0 || read < 0 || named == read) return "";
  const auto classes = classify_joints(skel);
  const auto& of_named = classes[static_cast<std::size_t>(named)];
  const std::string canonical = canonical_joint_name(of_named.first, of_named.second);
  return fmt::format(
      "{}: read as the {} (joint \"{}\" of {}), but {}'s joint \"{}\" is its {}; joint names "
      "mean body parts on every rig (docs/body-model.md){}",
      path, part_words(classes[static_cast<std::size_t>(read)]),
      skel.names[static_cast<std::size_t>(read)], rig, rig, name, part_words(of_named),
      canonical.empty() ? "" : "; write \"" + canonical + "\" for that joint");
}

}  // namespace

std::string joint_did_you_mean(const Skeleton& skeleton, const std::string& name) {
  std::vector<std::string> names = skeleton.names;
  for (const SegmentClass c : kMassiveClasses)
    for (const Side side : {Side::center, Side::left, Side::right}) {
      std::string canonical = canonical_joint_name(c, side);
      if (!canonical.empty() && std::find(names.begin(), names.end(), canonical) == names.end())
        names.push_back(std::move(canonical));
    }
  const std::string best = closest_name(name, names);
  return best.empty() ? "" : "did you mean \"" + best + "\"? ";
}

std::vector<std::string> joint_name_warnings(const Query& q, std::size_t i,
                                             const Skeleton& skeleton, const std::string& rig,
                                             const Skeleton* file_skeleton,
                                             const std::string& file) {
  const QueryFrameSpec& spec = q.frames[i];
  const std::string at = fmt::format("frames[{}]", i);
  std::vector<std::string> out;
  auto add = [&](std::string w) {
    if (!w.empty()) out.push_back(std::move(w));
  };
  for (const auto& jr : spec.joints)
    add(name_warning(at + ".joints." + jr.name, jr.name, skeleton, rig));
  for (const EffectorSpec& e : spec.effectors)
    add(name_warning(at + ".effectors." + e.name, e.name, skeleton, rig));
  if (file_skeleton)
    for (std::size_t k = 0; k < spec.only.size(); ++k)
      add(name_warning(fmt::format("{}.only[{}]", at, k), spec.only[k], *file_skeleton, file));
  return out;
}

}  // namespace mocap
