// The build plan (build_plan.hpp): the reuse decision, per-file plans, the
// up-to-date check; and character_json, the canonical character compared by
// the reuse decision.
#include "build_plan.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <map>
#include <nlohmann/json.hpp>
#include <set>
#include <unordered_map>

#include "mocap/common/util/error.hpp"
#include "mocap/common/util/json_text.hpp"
#include "mocap/common/util/xxh64.hpp"

namespace mocap {

namespace fs = std::filesystem;

std::string character_json(const Character& ch) {
  nlohmann::json j;
  j["name"] = ch.name;
  j["total_mass_kg"] = ch.total_mass_kg;
  j["sex"] = ch.sex == Sex::male ? "male" : "female";
  auto classes = [](const std::map<SegmentClass, double>& m) {
    nlohmann::json o = nlohmann::json::object();
    for (const auto& [k, v] : m) o[segment_class_name(k)] = v;
    return o;
  };
  auto joints = [](const std::map<std::string, double>& m) {
    nlohmann::json o = nlohmann::json::object();
    for (const auto& [k, v] : m) o[k] = v;
    return o;
  };
  j["class_mass_kg"] = classes(ch.class_mass_kg);
  j["class_mass_scale"] = classes(ch.class_mass_scale);
  j["joint_mass_kg"] = joints(ch.joint_mass_kg);
  j["class_length_scale"] = classes(ch.class_length_scale);
  j["joint_length_scale"] = joints(ch.joint_length_scale);
  return json_text(j);  // nlohmann::json objects keep keys sorted
}

BuildParameters build_parameters(const IndexInfo& info) {
  return {info.character_json, info.unit_option, info.transition_time_s, info.energy_params};
}

PreviousIndexChoice choose_previous_index(const fs::path& out, const IndexInfo& info, bool full) {
  PreviousIndexChoice choice;
  std::error_code ec;
  if (full || !fs::exists(out, ec)) return choice;
  try {
    Index old = Index::open(out);
    if (old.info().schema_version != kIndexSchemaVersion)
      choice.note = "index schema version " + std::to_string(old.info().schema_version) +
                    " (this build writes " + std::to_string(kIndexSchemaVersion) +
                    "): everything re-parsed";
    else if (old.info().build_tool != info.build_tool)
      choice.note = "built by " + old.info().build_tool + ": everything re-parsed";
    else if (build_parameters(old.info()) != build_parameters(info))
      choice.note =
          "build parameters changed (character, unit or transition time): everything re-parsed";
    else
      choice.index = std::make_unique<PreviousIndex>(out, std::move(old));
  } catch (const InputError& e) {
    choice.note =
        std::string("existing index not reusable (") + e.detail() + "): everything re-parsed";
  }
  return choice;
}

std::vector<PlannedFile> list_planned_files(const Collection& collection) {
  std::vector<PlannedFile> files;
  std::set<std::string> seen;
  for (const auto& e : collection.files) {
    std::string p = fs::absolute(e.path).lexically_normal().string();
    if (!seen.insert(p).second) continue;
    PlannedFile f;
    f.path = std::move(p);
    files.push_back(std::move(f));
  }
  std::sort(files.begin(), files.end(),
            [](const PlannedFile& a, const PlannedFile& b) { return a.path < b.path; });
  return files;
}

std::uint64_t amc_content_hash(std::uint64_t amc_hash, std::uint64_t asf_hash,
                               double frame_time_s) {
  std::uint64_t h = xxh64(&asf_hash, sizeof asf_hash, amc_hash);
  return xxh64(&frame_time_s, sizeof frame_time_s, h);
}

namespace {

/// The content hash the previous index would hold for this file unchanged.
std::uint64_t current_content_hash(const PlannedFile& f, const AmcReadOptions& amc) {
  const std::uint64_t h = hash_file(f.path);
  return f.amc ? amc_content_hash(h, hash_file(f.asf), amc.frame_time_s) : h;
}

/// stat, labels, the ASF of an AMC take and the plan of one file.
void plan_file(PlannedFile& f, const std::unordered_map<std::string, const IndexClip*>& old_clips,
               const std::unordered_map<std::string, const IndexSkippedFile*>& old_skips,
               const AmcReadOptions& amc) {
  if (has_amc_extension(f.path)) {
    f.amc = true;
    AsfPairing pairing = pair_asf(f.path, amc.asf);
    f.asf = std::move(pairing.asf);
    f.asf_error = std::move(pairing.error);
  }
  try {
    f.stat = stat_file(f.path);
  } catch (const InputError& e) {
    f.stat_error = e.detail();
  }
  f.labels = resolve_clip_labels(f.path);
  if (!f.stat) return;
  if (auto it = old_clips.find(f.path); it != old_clips.end()) {
    f.old_clip = it->second;
    if (f.old_clip->size_bytes != f.stat->size || f.old_clip->mtime_ns != f.stat->mtime_ns) return;
    // An unreadable file is parsed: that stage says why it fails.
    try {
      if (!f.amc || !f.asf.empty())
        if (current_content_hash(f, amc) == f.old_clip->content_hash) f.plan = FilePlan::reuse;
    } catch (const InputError&) {
    }
  } else if (auto sk = old_skips.find(f.path); sk != old_skips.end()) {
    f.old_skip = sk->second;
    // An AMC take is re-read while it has an ASF (the ASF may have changed).
    const bool same_pairing = !f.amc || (f.asf.empty() && f.old_skip->reason == f.asf_error);
    if (f.old_skip->mtime_ns == f.stat->mtime_ns && f.old_skip->size_bytes == f.stat->size &&
        same_pairing)
      f.plan = FilePlan::still_bad;
  }
}

}  // namespace

void plan_files(std::vector<PlannedFile>& files, const PreviousIndex* previous,
                const AmcReadOptions& amc, tbb::task_arena& arena) {
  std::unordered_map<std::string, const IndexClip*> old_clips;
  std::unordered_map<std::string, const IndexSkippedFile*> old_skips;
  if (previous) {
    for (const auto& c : previous->index().clips()) old_clips.emplace(c.path, &c);
    for (const auto& s : previous->index().skipped()) old_skips.emplace(s.path, &s);
  }
  arena.execute([&] {
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, files.size(), 4),
                      [&](const tbb::blocked_range<std::size_t>& r) {
                        for (std::size_t i = r.begin(); i != r.end(); ++i)
                          plan_file(files[i], old_clips, old_skips, amc);
                      });
  });
}

bool is_up_to_date(const std::vector<PlannedFile>& files, const Collection& collection,
                   const Index& old) {
  std::set<std::string> now;
  for (const auto& f : files) {
    now.insert(f.path);
    if (f.plan == FilePlan::parse) return false;
  }
  std::set<std::string> old_skips;
  for (const auto& s : old.skipped()) old_skips.insert(s.path);
  for (const auto& p : collection.problems)
    if (!old_skips.count(p.input)) return false;
  for (const auto& c : old.clips())
    if (!now.count(c.path)) return false;
  std::size_t skipped_missing = 0;
  for (const auto& s : old.skipped())
    if (!now.count(s.path)) ++skipped_missing;
  if (skipped_missing != collection.problems.size()) return false;
  for (const auto& f : files) {
    if (f.plan != FilePlan::reuse) continue;
    std::vector<std::string> labels(old.label_keys().size());
    for (const auto& [k, v] : f.labels.labels) {
      const auto it = std::find(old.label_keys().begin(), old.label_keys().end(), k);
      if (it == old.label_keys().end()) return false;
      labels[static_cast<std::size_t>(it - old.label_keys().begin())] = v;
    }
    if (labels != f.old_clip->labels || f.labels.source != f.old_clip->label_source) return false;
  }
  return true;
}

}  // namespace mocap
