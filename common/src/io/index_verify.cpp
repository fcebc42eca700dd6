// `mocap-index verify` (verify_index): every check of an index file, damage
// reported as problems, never thrown.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <string>
#include <type_traits>
#include <vector>

#include "io/index_checksum.hpp"
#include "mocap/common/io/hdf5.hpp"
#include "mocap/common/io/index.hpp"
#include "mocap/common/util/error.hpp"
#include "mocap/common/util/xxh64.hpp"

namespace mocap {

namespace fs = std::filesystem;

namespace {

void check_checksum(const h5::Dataset& d, std::vector<std::string>& problems) {
  if (!d.has_attribute("checksum_xxh64"))
    throw InputError(d.file(), 0, d.path() + ": checksum_xxh64 attribute is missing");
  const std::string expected = d.string_attribute("checksum_xxh64");
  ValueFindings found;
  const std::string leaf = d.path().substr(d.path().rfind('/') + 1);
  const bool quaternions = d.path().find("/frames/") != std::string::npos &&
                           (leaf == "local_rotations" || leaf == "world_rotations");
  const std::string got = hex64(dataset_checksum(d, &found, quaternions));
  if (got != expected)
    throw InputError(
        d.file(), 0,
        d.path() + ": checksum mismatch (xxh64 " + got + ", expected " + expected + ")");
  if (found.first_non_finite != UINT64_MAX)
    problems.push_back(d.path() + ": non-finite value at element " +
                       std::to_string(found.first_non_finite));
  if (found.first_bad_quaternion != UINT64_MAX)
    problems.push_back(d.path() + ": element " + std::to_string(found.first_bad_quaternion) +
                       " is not a unit quaternion with w >= 0");
}

void walk_datasets(const h5::Group& g, std::vector<h5::Dataset>& out) {
  for (const auto& name : g.members()) {
    if (g.is_group(name))
      walk_datasets(g.open_group(name), out);
    else
      out.push_back(g.open_dataset(name));
  }
}

void check_bounds(const Index& index, std::uint32_t k, std::vector<std::string>& problems) {
  const IndexSkeleton& s = index.skeletons()[k];
  const std::string where = "/skeletons/" + std::to_string(k);
  // Energy prefix sums: 0 on each clip's first frame, never decreasing.
  const IndexArray& prefix = index.array(k, "frames", "energy_prefix_J");
  for (std::size_t c : s.clips) {
    const IndexClip& clip = index.clips()[c];
    bool bad = prefix.f64[clip.frame_start] != 0.0;
    for (std::uint64_t f = clip.frame_start + 1; f < clip.frame_start + clip.frame_count && !bad;
         ++f)
      bad = prefix.f64[f] < prefix.f64[f - 1];
    if (bad)
      problems.push_back(where + "/frames/energy_prefix_J: clip " + clip.path +
                         " is not a prefix sum from 0");
  }
  for (const char* q : {"local_rotations", "world_rotations"}) {
    const IndexArray& a = index.array(k, "frames", q);
    for (std::size_t i = 0; i + 3 < a.f32.size(); i += 4) {
      double n2 = 0.0;
      for (std::size_t e = 0; e < 4; ++e)
        n2 += static_cast<double>(a.f32[i + e]) * static_cast<double>(a.f32[i + e]);
      const double n = std::sqrt(n2);
      if (std::abs(n - 1.0) > 1e-3 || a.f32[i] < 0.0f) {
        problems.push_back(where + "/frames/" + q + ": element " + std::to_string(i / 4) +
                           " is not a unit quaternion with w >= 0");
        break;
      }
    }
  }
  // Bounds contain their frames (clip level and block level).
  const IndexArray& root = index.array(k, "frames", "root_position_m");
  const IndexArray& kd = index.array(k, "frames", "kd_features");
  const IndexArray& cmin = index.array(k, "clip_bounds", "root_min_m");
  const IndexArray& cmax = index.array(k, "clip_bounds", "root_max_m");
  const IndexArray& kmin = index.array(k, "clip_bounds", "kd_min");
  const IndexArray& kmax = index.array(k, "clip_bounds", "kd_max");
  for (std::size_t c : s.clips) {
    const IndexClip& clip = index.clips()[c];
    bool bad = false;
    for (std::uint64_t f = clip.frame_start; f < clip.frame_start + clip.frame_count && !bad; ++f) {
      for (std::size_t e = 0; e < 3; ++e) {
        const float v = root.f32[f * 3 + e];
        if (v < cmin.f32[clip.row * 3 + e] || v > cmax.f32[clip.row * 3 + e]) bad = true;
      }
      for (std::size_t e = 0; e < kd.row_elements; ++e) {
        const float v = kd.f32[f * kd.row_elements + e];
        if (v < kmin.f32[clip.row * kd.row_elements + e] ||
            v > kmax.f32[clip.row * kd.row_elements + e])
          bad = true;
      }
    }
    if (bad)
      problems.push_back(where + "/clip_bounds: clip " + clip.path +
                         " has frames outside its bounds");
    for (std::size_t bi = 0; bi < kIndexBlockSizes.size(); ++bi) {
      const std::size_t bs = kIndexBlockSizes[bi];
      const std::string grp = "blocks" + std::to_string(bs);
      const IndexArray& bmin = index.array(k, grp, "kd_min");
      const IndexArray& bmax = index.array(k, grp, "kd_max");
      const std::uint64_t b0 = bi == 0 ? clip.block16_start : clip.block64_start;
      bool bbad = false;
      for (std::uint64_t f = 0; f < clip.frame_count && !bbad; ++f) {
        const std::uint64_t b = b0 + f / bs;
        for (std::size_t e = 0; e < kd.row_elements; ++e) {
          const float v = kd.f32[(clip.frame_start + f) * kd.row_elements + e];
          if (v < bmin.f32[b * kd.row_elements + e] || v > bmax.f32[b * kd.row_elements + e])
            bbad = true;
        }
      }
      if (bbad)
        problems.push_back(where + "/" + grp + ": clip " + clip.path +
                           " has frames outside its block bounds");
    }
  }
}

}  // namespace

IndexVerifyReport verify_index(const fs::path& path) {
  IndexVerifyReport r;
  std::error_code ec;
  r.bytes = fs::file_size(path, ec);
  try {
    check_index_file(path, true);
  } catch (const InputError& e) {
    r.problems.push_back(e.detail());
    return r;
  }
  try {
    const Index index = Index::open(path);
    {
      std::lock_guard lib(h5::library_mutex());
      h5::File f = h5::File::open(path);
      std::vector<h5::Dataset> all;
      walk_datasets(f.root(), all);
      for (const auto& d : all) {
        try {
          check_checksum(d, r.problems);
          ++r.datasets_checked;
        } catch (const InputError& e) {
          r.problems.push_back(e.detail());
        }
      }
      // Every schema array exists for every skeleton.
      for (std::size_t k = 0; k < index.skeletons().size(); ++k) {
        const h5::Group g = f.root().open_group("skeletons").open_group(std::to_string(k));
        auto need = [&](const char* grp, std::span<const IndexFieldSpec> table) {
          if (!g.exists(grp)) {
            r.problems.push_back(g.path() + "/" + grp + ": group is missing");
            return;
          }
          const h5::Group sub = g.open_group(grp);
          for (const auto& spec : table)
            if (!sub.exists(spec.name) &&
                (std::string_view(grp) != "frames" ||
                 frame_field_stored(spec.name, index.info().schema_version)))
              r.problems.push_back(sub.path() + "/" + spec.name + ": dataset is missing");
        };
        need("frames", kFrameFields);
        need("blocks16", kBlockFields);
        need("blocks64", kBlockFields);
        need("clip_bounds", kClipBoundFields);
      }
    }
    // One skeleton at a time, each with its own Index so that its arrays are
    // released before the next one is loaded (bounded memory).
    if (r.problems.empty())
      for (std::uint32_t k = 0; k < index.skeletons().size(); ++k) {
        const Index one = Index::open(path);
        check_bounds(one, k, r.problems);
      }
  } catch (const InputError& e) {
    r.problems.push_back(e.detail());
  } catch (const std::exception& e) {
    r.problems.push_back(std::string("unexpected error: ") + e.what());
  }
  r.ok = r.problems.empty();
  return r;
}

}  // namespace mocap
