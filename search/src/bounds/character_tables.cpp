// Tables for query characters (character_tables.hpp): the index's poses
// re-measured with another character's bone lengths and body, built once per
// engine and character.
#include "bounds/character_tables.hpp"

#include <fmt/format.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <map>
#include <nlohmann/json.hpp>
#include <string>

#include "bounds/bound_tables.hpp"
#include "mocap/common/dynamics/newton_euler.hpp"
#include "mocap/common/util/error.hpp"

namespace mocap::search_detail {

namespace {

constexpr std::size_t kCharacterCacheEntries = 4;

// Everything of a character that the energy depends on (not its name).
std::string character_key(const Character& c) {
  std::string out = fmt::format("{:.17g}|{}", c.total_mass_kg, c.sex == Sex::male ? "m" : "f");
  for (const auto& [k, v] : c.class_mass_kg)
    out += fmt::format("|cm{}={:.17g}", static_cast<int>(k), v);
  for (const auto& [k, v] : c.class_mass_scale)
    out += fmt::format("|cs{}={:.17g}", static_cast<int>(k), v);
  for (const auto& [k, v] : c.joint_mass_kg) out += fmt::format("|jm{}={:.17g}", k, v);
  for (const auto& [k, v] : c.class_length_scale)
    out += fmt::format("|cl{}={:.17g}", static_cast<int>(k), v);
  for (const auto& [k, v] : c.joint_length_scale) out += fmt::format("|jl{}={:.17g}", k, v);
  return out;
}

// The same body (the name never changes it).
bool same_character(const Character& x, const Character& y) {
  return static_cast<const BodySettings&>(x) == static_cast<const BodySettings&>(y);
}

// The index's character from its `character` attribute: the indexer's
// canonical form (index_builder.cpp character_json: every map written out),
// or a character file's form; nullopt when neither parses (then every query
// character gets its own tables).
std::optional<Character> index_character(const Index& index) {
  const std::string& text = index.info().character_json;
  try {
    const auto j = nlohmann::json::parse(text);
    if (j.is_object() && j.contains("class_mass_kg")) {
      using Map = std::map<std::string, double>;
      Character c;
      c.name = j.at("name").get<std::string>();
      c.total_mass_kg = j.at("total_mass_kg").get<double>();
      c.sex = j.at("sex").get<std::string>() == "female" ? Sex::female : Sex::male;
      auto classes = [&](const char* key, std::map<SegmentClass, double>& out) {
        for (const auto& [name, v] : j.at(key).get<Map>()) {
          const auto cls = parse_segment_class(name);
          if (!cls)
            throw InputError(index.path().string(), 0, "character: unknown segment class " + name);
          out[*cls] = v;
        }
      };
      classes("class_mass_kg", c.class_mass_kg);
      classes("class_mass_scale", c.class_mass_scale);
      c.joint_mass_kg = j.at("joint_mass_kg").get<Map>();
      classes("class_length_scale", c.class_length_scale);
      c.joint_length_scale = j.at("joint_length_scale").get<Map>();
      return c;
    }
    return parse_character_json(text, index.path().string());
  } catch (const std::exception&) {
    return std::nullopt;
  }
}

// A character's tables for skeleton k: the index's skeleton with the
// character's length scales, its body and model; per-frame dynamics
// recomputed from the stored world pose (joint positions moved for the new
// bone lengths, rotations unchanged) exactly as the indexer computes them.
std::unique_ptr<SkeletonData> make_character_skeleton(const Index& index, std::uint32_t k,
                                                      const Character& ch) {
  const IndexSkeleton& isk = index.skeletons()[k];
  Skeleton base = isk.skeleton;
  base.translation_scales.clear();
  const Skeleton scaled = apply_length_scales(base, ch);
  const Body body = build_body(scaled, ch);
  DynamicsModel model = build_dynamics_model(scaled, body, index.info().energy_params);
  if (model.segments.empty())
    throw InputError("character", 0,
                     "no joint of the index skeleton carries mass with this character");
  auto skeleton = std::make_unique<SkeletonData>();
  init_skeleton_data(index, k, std::move(model), *skeleton);
  SkeletonTables& tables = skeleton->tables;
  skeleton->character = std::make_unique<CharacterFrames>();
  CharacterFrames& own = *skeleton->character;
  // Query frames are posed on the character's skeleton (resolve_frame).
  own.skeleton = isk;
  own.skeleton.skeleton = scaled;
  own.skeleton.body = body;
  tables.sk = &own.skeleton;
  const std::size_t nj = tables.model.joint_count(), n = isk.frame_count, s = tables.segments;
  own.joint_ratio.assign(nj, 1.0);
  bool scaled_bones = false;
  for (std::size_t j = 0; j < nj; ++j) {
    const double old_s =
        isk.skeleton.translation_scales.empty() ? 1.0 : isk.skeleton.translation_scales[j];
    const double new_s = scaled.translation_scales.empty() ? 1.0 : scaled.translation_scales[j];
    own.joint_ratio[j] = new_s / old_s;
    scaled_bones = scaled_bones || own.joint_ratio[j] != 1.0;
  }
  const float* pos = index.array(k, "frames", "joint_positions_m").f32.data();
  const float* rot = index.array(k, "frames", "world_rotations").f32.data();
  own.joint_positions_m.resize(n * nj * 3);
  own.kd_features.resize(n * s * 3);
  // The scan table field-major while the clips are computed in parallel,
  // then moved into the tiles (the only copy kept).
  HScanTable table;
  init_h_scan_table(tables.model, n, table);
  const double t_index = index.info().transition_time_s;
  tbb::parallel_for(std::size_t{0}, tables.clips.size(), [&](std::size_t r) {
    const ClipInfo& ci = tables.clips[r];
    const std::size_t kf = ci.frame_count;
    std::vector<Eigen::Vector3d> p(kf * nj);
    std::vector<Eigen::Quaterniond> q(kf * nj);
    for (std::size_t f = 0; f < kf; ++f)
      for (std::size_t j = 0; j < nj; ++j) {
        const std::size_t i = (ci.frame_start + f) * nj + j;
        const float* x = pos + i * 3;
        const float* w = rot + i * 4;
        q[f * nj + j] = Eigen::Quaterniond(w[0], w[1], w[2], w[3]).normalized();
        const Eigen::Vector3d pj(x[0], x[1], x[2]);
        const int par = tables.model.parents[j];
        if (!scaled_bones || par < 0) {
          p[f * nj + j] = pj;
        } else {
          // x'_j = x'_parent + ratio_j (x_j - x_parent): the bone from the parent, rescaled.
          const auto pp = static_cast<std::size_t>(par);
          const float* xp = pos + ((ci.frame_start + f) * nj + pp) * 3;
          p[f * nj + j] =
              p[f * nj + pp] + own.joint_ratio[j] * (pj - Eigen::Vector3d(xp[0], xp[1], xp[2]));
        }
      }
    ClipDynamics dyn;
    compute_clip_dynamics(tables.model, kf, index.clips()[ci.clip].frame_time_s, p.data(), q.data(),
                          dyn);
    for (std::size_t f = 0; f < kf; ++f) {
      const std::size_t g = ci.frame_start + f;
      set_h_scan_frame(tables.model, dyn.state(f), g, table);
      const Eigen::Vector3d& root =
          dyn.joint_positions_m[f * nj + static_cast<std::size_t>(isk.root_joint)];
      for (std::size_t a = 0; a < 3; ++a)
        table.root_positions[a * table.stride + g] =
            static_cast<float>(root[static_cast<Eigen::Index>(a)]);
      for (std::size_t j = 0; j < nj; ++j)
        for (std::size_t a = 0; a < 3; ++a) {
          const auto e = static_cast<Eigen::Index>(a);
          own.joint_positions_m[(g * nj + j) * 3 + a] =
              static_cast<float>(dyn.joint_positions_m[f * nj + j][e]);
        }
      kd_feature(tables.model, dyn.state(f), t_index, own.kd_features.data() + g * s * 3);
    }
  });
  tables.kd = own.kd_features.data();
  set_tiles_from_table(tables, table);
  table = HScanTable();
  build_bound_tables(tables);
  return skeleton;
}

}  // namespace

CharacterTableCache::CharacterTableCache(const Index& index)
    : index_(&index), index_character_(index_character(index)) {}

std::shared_ptr<const CharacterTables> CharacterTableCache::tables_for(const Query& q) const {
  if (!q.character) return nullptr;
  Character ch;
  try {
    ch = read_character_file(*q.character);
  } catch (const InputError& e) {
    throw InputError("query " + q.id, 0, std::string("character: ") + e.what());
  }
  if (index_character_ && same_character(ch, *index_character_)) return nullptr;
  const std::string key = character_key(ch);
  std::shared_ptr<CharacterTables> tables;
  {
    std::lock_guard lock(mutex_);
    auto it = entries_.find(key);
    if (it == entries_.end()) {
      // Bounded: drop the others (queries running with them keep their tables alive).
      if (entries_.size() >= kCharacterCacheEntries) entries_.clear();
      it = entries_.emplace(key, std::make_shared<CharacterTables>()).first;
    }
    tables = it->second;
  }
  // Isolated (see clip_prefix): the builder's parallel_for must not run
  // another query's task that would wait on this flag.
  std::call_once(tables->once, [&] {
    tbb::this_task_arena::isolate([&] {
      try {
        for (std::uint32_t k = 0; k < index_->skeletons().size(); ++k)
          tables->skeletons.push_back(make_character_skeleton(*index_, k, ch));
      } catch (const std::exception& e) {
        tables->skeletons.clear();
        tables->build_error = e.what();
      }
    });
  });
  if (!tables->build_error.empty())
    throw InputError("query " + q.id, 0,
                     fmt::format("character {}: {}", q.character->string(), tables->build_error));
  return tables;
}

}  // namespace mocap::search_detail
