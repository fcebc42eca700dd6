// build_index: the TBB pipeline, the HDF5 writer, labels and atomic replace.
#include "mocap/index_builder.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_pipeline.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <exception>
#include <fstream>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <set>
#include <thread>
#include <unordered_map>

#include "mocap/atomic_file.hpp"
#include "mocap/bvh.hpp"
#include "mocap/collection.hpp"
#include "mocap/error.hpp"
#include "mocap/file.hpp"
#include "mocap/hdf5.hpp"
#include "mocap/xxh64.hpp"

namespace mocap {

namespace fs = std::filesystem;

// ---------------------------------------------------------------------------
// Character and labels

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
  return j.dump();  // nlohmann::json objects keep keys sorted
}

namespace {

std::vector<std::string> split(const std::string& s, char sep) {
  std::vector<std::string> out;
  std::size_t start = 0;
  while (true) {
    const std::size_t p = s.find(sep, start);
    out.push_back(s.substr(start, p == std::string::npos ? std::string::npos : p - start));
    if (p == std::string::npos) break;
    start = p + 1;
  }
  return out;
}

bool all_digits(const std::string& s) {
  return !s.empty() &&
         std::all_of(s.begin(), s.end(), [](unsigned char c) { return c >= '0' && c <= '9'; });
}

/// Line `n` (0-based) of cfg/<key>_label.txt near the clip, if any.
std::optional<std::string> cfg_label(const fs::path& bvh, const std::string& key, long long n) {
  if (n < 0) return std::nullopt;
  fs::path dir = bvh.parent_path();
  for (int up = 0; up < 3 && !dir.empty(); ++up, dir = dir.parent_path()) {
    const fs::path cfg = dir / "cfg" / (key + "_label.txt");
    std::error_code ec;
    if (!fs::is_regular_file(cfg, ec)) continue;
    std::ifstream in(cfg);
    std::string line;
    for (long long i = 0; std::getline(in, line); ++i) {
      if (i != n) continue;
      while (!line.empty() && (line.back() == '\r' || line.back() == ' ' || line.back() == '\t'))
        line.pop_back();
      // Drop a collection prefix ("dataset-1_") that also starts the file name.
      const std::size_t us = line.find('_');
      const std::string stem = bvh.stem().string();
      if (us != std::string::npos && us + 1 < line.size() &&
          stem.compare(0, us + 1, line, 0, us + 1) == 0)
        line = line.substr(us + 1);
      return line;
    }
    return std::nullopt;
  }
  return std::nullopt;
}

}  // namespace

ClipLabels resolve_clip_labels(const fs::path& bvh) {
  ClipLabels out;
  fs::path sidecar = bvh;
  sidecar.replace_extension(".json");
  std::error_code ec;
  if (fs::is_regular_file(sidecar, ec)) {
    std::ifstream in(sidecar);
    const nlohmann::json j = nlohmann::json::parse(in, nullptr, false);
    if (j.is_object()) {
      out.source = LabelSource::sidecar;
      for (const auto& [key, value] : j.items()) {
        std::string label;
        if (value.is_number_integer()) {
          if (auto l = cfg_label(bvh, key, value.get<long long>())) {
            label = *l;
            out.source = LabelSource::sidecar_cfg;
          } else {
            label = std::to_string(value.get<long long>());
          }
        } else if (value.is_string()) {
          label = value.get<std::string>();
        } else {
          label = value.dump();
        }
        out.labels.emplace_back(key, label);
      }
      std::sort(out.labels.begin(), out.labels.end());
      return out;
    }
  }
  const auto parts = split(bvh.stem().string(), '_');
  if (parts.size() >= 4 && all_digits(parts.back())) {
    std::string content = parts[1];
    for (std::size_t i = 2; i + 2 < parts.size(); ++i) content += "_" + parts[i];
    out.source = LabelSource::file_name;
    out.labels = {{"content", content}, {"style", parts[parts.size() - 2]}};
  }
  return out;
}

// ---------------------------------------------------------------------------
// The writer

namespace {

constexpr std::size_t kFlushValues = 1u << 18;  // 1 MB of float32 per column buffer
constexpr std::size_t kChunkValues = 1u << 14;  // 64 KB chunks

std::string axes_of(RowShape s) {
  switch (s) {
    case RowShape::scalar:
      return "row";
    case RowShape::vec3:
      return "row, (x, y, z)";
    case RowShape::joints3:
      return "row, joint, (x, y, z)";
    case RowShape::joints4:
      return "row, joint, (w, x, y, z)";
    case RowShape::segments3:
      return "row, segment, (x, y, z)";
    case RowShape::segments9:
      return "row, segment, value";
  }
  return "row";
}

/// An appendable float32 or float64 column with a running checksum.
struct Column {
  h5::Dataset ds;
  Xxh64 hash;
  std::vector<float> pending;
  std::vector<double> pending64;
  std::size_t row_elements = 0;
  const IndexFieldSpec* spec = nullptr;

  void add(const float* v, std::size_t rows) {
    const std::size_t n = rows * row_elements;
    hash.update(v, n * sizeof(float));
    pending.insert(pending.end(), v, v + n);
    if (pending.size() >= kFlushValues) flush();
  }
  void add(const double* v, std::size_t rows) {
    const std::size_t n = rows * row_elements;
    hash.update(v, n * sizeof(double));
    pending64.insert(pending64.end(), v, v + n);
    if (pending64.size() >= kFlushValues / 2) flush();
  }
  void flush() {
    if (!pending.empty()) ds.append_rows(pending.data(), pending.size() / row_elements);
    if (!pending64.empty()) ds.append_rows(pending64.data(), pending64.size() / row_elements);
    pending.clear();
    pending64.clear();
  }
  void finish() {
    flush();
    ds.set_attribute("unit", spec->unit);
    ds.set_attribute("description", spec->description);
    ds.set_attribute("axes", axes_of(spec->shape));
    ds.set_attribute("checksum_xxh64", hex64(hash.digest()));
  }
};

void describe(h5::Dataset& d, std::string_view unit, std::string_view description,
              std::uint64_t checksum) {
  d.set_attribute("unit", unit);
  d.set_attribute("description", description);
  d.set_attribute("checksum_xxh64", hex64(checksum));
}

template <class T>
void put(h5::Group& g, const std::string& name, const std::vector<hsize_t>& shape,
         const std::vector<T>& values, std::string_view unit, std::string_view description) {
  h5::Dataset d = g.write_dataset<T>(name, shape, std::span<const T>(values));
  describe(d, unit, description, xxh64(values.data(), values.size() * sizeof(T)));
}

void put_strings(h5::Group& g, const std::string& name, const std::vector<hsize_t>& shape,
                 const std::vector<std::string>& values, std::string_view description) {
  h5::Dataset d = g.write_strings(name, shape, values);
  Xxh64 h;
  for (const auto& s : values) h.update(s.c_str(), s.size() + 1);
  describe(d, "", description, h.digest());
}

void put_enum(h5::Group& g, const std::string& name, const std::vector<std::uint8_t>& values,
              const std::vector<std::pair<std::string, int>>& members,
              std::string_view description) {
  h5::Dataset d = g.create_enum_dataset(name, values.size(), members);
  d.write_enum(values);
  describe(d, "", description, xxh64(values.data(), values.size()));
}

struct RootAttributes {
  std::string build_tool;
  std::string character_json;
  std::string character_name;
  double character_total_mass_kg = 0.0;
  double transition_time_s = 0.5;
  std::string unit_option;
  int deflate_level = 0;
  EnergyParams energy;
};

/// One skeleton's group and its appendable columns.
struct Slot {
  IndexSkeleton table;
  h5::Group group;
  std::array<Column, kFrameFieldCount> frames;
  std::array<std::array<Column, kBlockFieldCount>, kIndexBlockSizes.size()> blocks;
  std::array<Column, kClipBoundFieldCount> bounds;
};

/// Datasets of the previous index, opened once, for copying reused clips.
class PreviousIndex {
 public:
  PreviousIndex(const fs::path& path, Index index)
      : index_(std::move(index)), file_(h5::File::open(path)) {}
  const Index& index() const { return index_; }
  const h5::Dataset& dataset(std::uint32_t skeleton, const std::string& group, const char* field) {
    const std::string key = std::to_string(skeleton) + "/" + group + "/" + field;
    auto it = open_.find(key);
    if (it == open_.end()) {
      h5::Dataset d = file_.root()
                          .open_group("skeletons")
                          .open_group(std::to_string(skeleton))
                          .open_group(group)
                          .open_dataset(field);
      it = open_.emplace(key, std::move(d)).first;
    }
    return it->second;
  }

 private:
  Index index_;
  h5::File file_;
  std::unordered_map<std::string, h5::Dataset> open_;
};

class IndexWriter {
 public:
  IndexWriter(const fs::path& path, int deflate_level)
      : file_(h5::File::create(path, kIndexUserBlockBytes)), deflate_(deflate_level) {
    skeletons_ = file_.root().create_group("skeletons");
  }

  /// Slot of a skeleton (by id), created on first use.
  std::uint32_t slot_for(const IndexSkeleton& s) {
    if (auto it = by_id_.find(s.id); it != by_id_.end()) return it->second;
    const auto k = static_cast<std::uint32_t>(slots_.size());
    auto slot = std::make_unique<Slot>();
    slot->table = s;
    slot->table.clips.clear();
    slot->table.frame_count = slot->table.block16_count = slot->table.block64_count = 0;
    slot->group = skeletons_.create_group(std::to_string(k));
    const std::size_t J = s.skeleton.joint_count(), S = s.segments.size();
    auto make = [&](h5::Group& g, Column& c, const IndexFieldSpec& spec, int deflate) {
      c.spec = &spec;
      c.row_elements = row_elements(spec.shape, J, S);
      std::vector<hsize_t> shape{0};
      for (auto d : row_dims(spec.shape, J, S)) shape.push_back(d);
      h5::DatasetOptions o;
      o.chunk_rows = std::max<std::size_t>(16, kChunkValues / c.row_elements);
      o.deflate_level = deflate;
      c.ds = spec.dtype == IndexDType::f32 ? g.create_dataset<float>(spec.name, shape, o)
                                           : g.create_dataset<double>(spec.name, shape, o);
    };
    h5::Group frames = slot->group.create_group("frames");
    for (std::size_t i = 0; i < kFrameFieldCount; ++i)
      make(frames, slot->frames[i], kFrameFields[i], deflate_);
    // Bounds are small and compress well: always deflated.
    for (std::size_t b = 0; b < kIndexBlockSizes.size(); ++b) {
      h5::Group g = slot->group.create_group("blocks" + std::to_string(kIndexBlockSizes[b]));
      for (std::size_t i = 0; i < kBlockFieldCount; ++i)
        make(g, slot->blocks[b][i], kBlockFields[i], 4);
    }
    h5::Group cb = slot->group.create_group("clip_bounds");
    for (std::size_t i = 0; i < kClipBoundFieldCount; ++i)
      make(cb, slot->bounds[i], kClipBoundFields[i], 4);
    slots_.push_back(std::move(slot));
    by_id_.emplace(s.id, k);
    return k;
  }

  /// Appends a parsed clip; fills clip.row, frame_start and block starts.
  void append(IndexClip& clip, std::size_t clip_index, const ClipFrameData& d) {
    Slot& s = place(clip, clip_index, d.frame_count);
    for (std::size_t i = 0; i < kFrameFieldCount; ++i) {
      if (kFrameFields[i].dtype == IndexDType::f32)
        s.frames[i].add(d.frames[i].data(), d.frame_count);
      else
        s.frames[i].add(d.frames_f64[i].data(), d.frame_count);
    }
    for (std::size_t b = 0; b < kIndexBlockSizes.size(); ++b) {
      const std::size_t blocks = (d.frame_count + kIndexBlockSizes[b] - 1) / kIndexBlockSizes[b];
      for (std::size_t i = 0; i < kBlockFieldCount; ++i)
        s.blocks[b][i].add(d.blocks[b][i].data(), blocks);
    }
    for (std::size_t i = 0; i < kClipBoundFieldCount; ++i)
      s.bounds[i].add(d.clip_bounds[i].data(), 1);
  }

  /// Copies a reused clip's rows from the previous index.
  void copy(IndexClip& clip, std::size_t clip_index, PreviousIndex& prev, const IndexClip& old) {
    Slot& s = place(clip, clip_index, old.frame_count);
    std::vector<float> buf;
    std::vector<double> buf64;
    auto copy_rows = [&](Column& c, const std::string& group, std::uint64_t first,
                         std::uint64_t count) {
      const h5::Dataset& src = prev.dataset(old.skeleton, group, c.spec->name);
      if (c.spec->dtype == IndexDType::f32) {
        buf.resize(count * c.row_elements);
        src.read_rows_into<float>(first, count, buf.data());
        c.add(buf.data(), count);
      } else {
        buf64.resize(count * c.row_elements);
        src.read_rows_into<double>(first, count, buf64.data());
        c.add(buf64.data(), count);
      }
    };
    for (auto& c : s.frames) copy_rows(c, "frames", old.frame_start, old.frame_count);
    for (std::size_t b = 0; b < kIndexBlockSizes.size(); ++b) {
      const std::size_t bs = kIndexBlockSizes[b];
      const std::uint64_t first = b == 0 ? old.block16_start : old.block64_start;
      for (auto& c : s.blocks[b])
        copy_rows(c, "blocks" + std::to_string(bs), first, (old.frame_count + bs - 1) / bs);
    }
    for (auto& c : s.bounds) copy_rows(c, "clip_bounds", old.row, 1);
  }

  std::size_t skeleton_count() const { return slots_.size(); }

  /// Writes the tables and attributes and closes the file.
  void finish(const std::vector<IndexClip>& clips, const std::vector<std::string>& label_keys,
              const std::vector<IndexSkippedFile>& skipped,
              const std::vector<std::pair<std::int64_t, std::uint64_t>>& skipped_stat,
              const RootAttributes& attrs) {
    std::uint64_t frames = 0;
    for (const auto& c : clips) frames += c.frame_count;
    for (std::size_t k = 0; k < slots_.size(); ++k) finish_slot(*slots_[k]);
    write_clips(clips, label_keys);
    h5::Group sk = file_.root().create_group("skipped");
    std::vector<std::string> paths, reasons;
    std::vector<std::uint64_t> sizes;
    std::vector<std::int64_t> mtimes;
    for (std::size_t i = 0; i < skipped.size(); ++i) {
      paths.push_back(skipped[i].path);
      reasons.push_back(skipped[i].reason);
      mtimes.push_back(skipped_stat[i].first);
      sizes.push_back(skipped_stat[i].second);
    }
    put_strings(sk, "path", {paths.size()}, paths, "files that were not indexed");
    put_strings(sk, "reason", {reasons.size()}, reasons,
                "why (file:line: what was expected, or an I/O error)");
    put(sk, "size_bytes", {sizes.size()}, sizes, "B",
        "file size when it was tried (0 for a missing input)");
    put(sk, "mtime_ns", {mtimes.size()}, mtimes, "ns",
        "modification time when it was tried, since the Unix epoch");

    h5::Group& r = file_.root();
    r.set_attribute("format", kIndexFormat);
    r.set_attribute("schema_version", kIndexSchemaVersion);
    r.set_attribute(
        "description",
        "motion-capture index: clips, skeletons, per-frame kinematics and dynamics, bounds "
        "(docs/index-format.md)");
    r.set_attribute("length_unit", "m");
    r.set_attribute("time_unit", "s");
    r.set_attribute("mass_unit", "kg");
    r.set_attribute("energy_unit", "J");
    r.set_attribute("angle_unit", "rad (quaternions are unitless; *_deg datasets are degrees)");
    r.set_attribute("up_axis", "Y");
    r.set_attribute("build_tool", attrs.build_tool);
    r.set_attribute("build_time_utc", utc_now());
    r.set_attribute("character", attrs.character_json);
    r.set_attribute("character_name", attrs.character_name);
    r.set_attribute("character_total_mass_kg", attrs.character_total_mass_kg);
    r.set_attribute("transition_time_s", attrs.transition_time_s);
    r.set_attribute("unit_option", attrs.unit_option);
    r.set_attribute("deflate_level", static_cast<std::int64_t>(attrs.deflate_level));
    r.set_attribute("gravity_mps2", attrs.energy.gravity_mps2);
    r.set_attribute("ground_height_m", attrs.energy.ground_height_m);
    r.set_attribute("contact_height_m", attrs.energy.contact_height_m);
    r.set_attribute("contact_speed_mps", attrs.energy.contact_speed_mps);
    r.set_attribute("friction_coefficient", attrs.energy.friction_coefficient);
    r.set_attribute("contact_patch_radius_m", attrs.energy.contact_patch_radius_m);
    const double blocks[] = {static_cast<double>(kIndexBlockSizes[0]),
                             static_cast<double>(kIndexBlockSizes[1])};
    r.set_attribute("block_sizes", std::span<const double>(blocks));
    r.set_attribute("clip_count", static_cast<std::int64_t>(clips.size()));
    r.set_attribute("frame_count", static_cast<std::int64_t>(frames));
    r.set_attribute("skeleton_count", static_cast<std::int64_t>(slots_.size()));
    r.set_attribute("skipped_count", static_cast<std::int64_t>(skipped.size()));
    slots_.clear();
    skeletons_ = h5::Group();
    file_.close();
  }

 private:
  Slot& place(IndexClip& clip, std::size_t clip_index, std::uint64_t frame_count) {
    Slot& s = *slots_.at(clip.skeleton);
    clip.row = s.table.clips.size();
    clip.frame_start = s.table.frame_count;
    clip.frame_count = frame_count;
    clip.block16_start = s.table.block16_count;
    clip.block64_start = s.table.block64_count;
    s.table.clips.push_back(clip_index);
    s.table.frame_count += frame_count;
    s.table.block16_count += (frame_count + 15) / 16;
    s.table.block64_count += (frame_count + 63) / 64;
    return s;
  }

  static std::string utc_now() {
    const std::time_t t = std::time(nullptr);
    std::tm tm{};
    gmtime_r(&t, &tm);
    char buf[32];
    std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%SZ", &tm);
    return buf;
  }

  void finish_slot(Slot& s) {
    for (auto& c : s.frames) c.finish();
    for (auto& b : s.blocks)
      for (auto& c : b) c.finish();
    for (auto& c : s.bounds) c.finish();
    const IndexSkeleton& t = s.table;
    const Skeleton& k = t.skeleton;
    const std::size_t J = k.joint_count();
    h5::Group& g = s.group;
    g.set_attribute("id", hex64(t.id));
    g.set_attribute("joint_count", static_cast<std::int64_t>(J));
    g.set_attribute("segment_count", static_cast<std::int64_t>(t.segments.size()));
    g.set_attribute("root_joint", static_cast<std::int64_t>(t.root_joint));
    g.set_attribute("unit_scale_m", k.unit_scale_m);
    g.set_attribute("total_mass_kg", t.body.total_mass_kg);
    g.set_attribute("clip_count", static_cast<std::int64_t>(t.clips.size()));
    g.set_attribute("frame_count", static_cast<std::int64_t>(t.frame_count));
    g.set_attribute("block16_count", static_cast<std::int64_t>(t.block16_count));
    g.set_attribute("block64_count", static_cast<std::int64_t>(t.block64_count));
    std::vector<double> offsets, ends, com, tip, inertia, mass, length, scales;
    std::vector<std::string> classes, sides;
    std::vector<std::uint8_t> has_end;
    for (std::size_t j = 0; j < J; ++j) {
      for (int a = 0; a < 3; ++a) {
        offsets.push_back(k.offsets_m[j][a]);
        ends.push_back(k.end_sites_m[j][a]);
      }
      has_end.push_back(k.has_end_site[j]);
      scales.push_back(k.translation_scales.empty() ? 1.0 : k.translation_scales[j]);
      const Segment& seg = t.body.segments[j];
      classes.emplace_back(segment_class_name(seg.cls));
      sides.emplace_back(side_name(seg.side));
      mass.push_back(seg.mass_kg);
      length.push_back(seg.length_m);
      for (int a = 0; a < 3; ++a) {
        com.push_back(seg.com_local_m[a]);
        tip.push_back(seg.tip_local_m[a]);
      }
      for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c) inertia.push_back(seg.inertia_local_kgm2(r, c));
    }
    const std::vector<std::int32_t> parents(k.parents.begin(), k.parents.end());
    const std::vector<std::int32_t> segments(t.segments.begin(), t.segments.end());
    put_strings(g, "names", {J}, k.names, "joint names in depth-first file order");
    put(g, "parents", {J}, parents, "", "parent joint index, -1 for a root; parents[j] < j");
    put(g, "offsets_m", {J, 3}, offsets, "m", "OFFSET (rest translation from the parent)");
    put(g, "end_sites_m", {J, 3}, ends, "m",
        "End Site offset in the joint frame (0 when has_end_site is 0)");
    put(g, "has_end_site", {J}, has_end, "", "1 when the joint has an End Site");
    put(g, "translation_scales", {J}, scales, "1",
        "multiplier on the joint's local translation (character length scales)");
    put_strings(g, "channels", {J}, t.channels, "the joint's BVH channels in file order");
    put_strings(g, "segment_class", {J}, classes,
                "body segment class of the joint (body.hpp), none = no mass");
    put_strings(g, "segment_side", {J}, sides, "center, left or right");
    put(g, "mass_kg", {J}, mass, "kg", "segment mass for the index's character");
    put(g, "com_local_m", {J, 3}, com, "m", "segment centre of mass in the joint frame");
    put(g, "tip_local_m", {J, 3}, tip, "m",
        "bone end (child, mean of children or End Site) in the joint frame");
    put(g, "inertia_local_kgm2", {J, 3, 3}, inertia, "kg m^2",
        "segment inertia tensor about its COM, joint frame");
    put(g, "segment_length_m", {J}, length, "m", "bone length of the segment");
    put(g, "segments", {segments.size()}, segments, "",
        "joints with mass (DynamicsModel::segments): the segment axis of h_scan and kd arrays");
  }

  void write_clips(const std::vector<IndexClip>& clips, const std::vector<std::string>& keys) {
    h5::Group g = file_.root().create_group("clips");
    const std::size_t C = clips.size();
    std::vector<std::string> paths, units, labels;
    std::vector<std::uint64_t> sizes, hashes, rows, fstart, fcount, b16, b64;
    std::vector<std::int64_t> mtimes;
    std::vector<std::uint32_t> skel;
    std::vector<double> ftime, uscale;
    std::vector<std::uint8_t> status, lsrc;
    for (const IndexClip& c : clips) {
      paths.push_back(c.path);
      sizes.push_back(c.size_bytes);
      mtimes.push_back(c.mtime_ns);
      hashes.push_back(c.content_hash);
      skel.push_back(c.skeleton);
      rows.push_back(c.row);
      fstart.push_back(c.frame_start);
      fcount.push_back(c.frame_count);
      b16.push_back(c.block16_start);
      b64.push_back(c.block64_start);
      ftime.push_back(c.frame_time_s);
      uscale.push_back(c.unit_scale_m);
      units.push_back(c.unit);
      status.push_back(static_cast<std::uint8_t>(c.status));
      lsrc.push_back(static_cast<std::uint8_t>(c.label_source));
      for (const auto& l : c.labels) labels.push_back(l);
    }
    put_strings(g, "path", {C}, paths, "absolute path of the source file; clips are sorted by it");
    put(g, "size_bytes", {C}, sizes, "B", "source file size");
    put(g, "mtime_ns", {C}, mtimes, "ns", "source file modification time since the Unix epoch");
    put(g, "content_xxh64", {C}, hashes, "", "XXH64 (seed 0) of the source file's bytes");
    put(g, "skeleton", {C}, skel, "", "group /skeletons/<skeleton> holding the clip's rows");
    put(g, "row", {C}, rows, "", "row of the clip in its skeleton's clip_bounds arrays");
    put(g, "frame_start", {C}, fstart, "", "first row of the clip in its skeleton's frames arrays");
    put(g, "frame_count", {C}, fcount, "", "number of frames (rows) of the clip");
    put(g, "block16_start", {C}, b16, "",
        "first row of the clip in blocks16 (ceil(frame_count / 16) rows)");
    put(g, "block64_start", {C}, b64, "",
        "first row of the clip in blocks64 (ceil(frame_count / 64) rows)");
    put(g, "frame_time_s", {C}, ftime, "s", "seconds between frames (the file's Frame Time)");
    put(g, "unit_scale_m", {C}, uscale, "m", "metres per file length unit");
    put_strings(g, "unit", {C}, units, "file length unit, declared (--unit) or detected");
    put_enum(g, "status", status, {{"new", 0}, {"changed", 1}, {"reused", 2}},
             "how this build obtained the clip: parsed (new file), parsed (changed file), reused "
             "from the previous index");
    put_enum(g, "label_source", lsrc,
             {{"none", 0}, {"file_name", 1}, {"sidecar", 2}, {"sidecar_cfg", 3}},
             "where the labels came from: none, the file name, the NAME.json sidecar, the sidecar "
             "resolved via cfg/*_label.txt");
    put_strings(g, "label_keys", {keys.size()}, keys, "label names, the columns of labels");
    put_strings(g, "labels", {C, keys.size()}, labels, "label of each clip per key (\"\" = none)");
  }

  h5::File file_;
  h5::Group skeletons_;
  int deflate_ = 0;
  std::vector<std::unique_ptr<Slot>> slots_;
  std::unordered_map<std::uint64_t, std::uint32_t> by_id_;
};

// ---------------------------------------------------------------------------
// Files

// ---------------------------------------------------------------------------
// Work items

enum class Plan : std::uint8_t { parse, reuse, still_bad };

struct FileEntry {
  std::string path;  // absolute, normal
  FileStat stat;
  bool stat_ok = false;
  std::string stat_error;
  Plan plan = Plan::parse;
  std::uint64_t hash = 0;  // known when plan == reuse
  const IndexClip* old_clip = nullptr;
  const IndexSkippedFile* old_skip = nullptr;
  ClipLabels labels;
};

/// What the parallel stage hands to the writer.
struct Work {
  std::size_t file = 0;
  bool ok = false;
  std::string reason;  // when !ok
  IndexClip clip;
  std::unique_ptr<IndexedSkeleton> skeleton;
  ClipFrameData data;
};

std::string failure_reason(const InputError& e) {
  return e.line() > 0 ? "line " + std::to_string(e.line()) + ": " + e.detail() : e.detail();
}

IndexSkeleton to_table(const IndexedSkeleton& s) {
  IndexSkeleton t;
  t.id = s.id;
  t.skeleton = s.skeleton;
  t.channels = s.channels;
  t.body = s.body;
  t.root_joint = s.root_joint;
  t.segments = s.model.segments;
  return t;
}

}  // namespace

IndexBuildSummary build_index(const IndexBuildOptions& opt) {
  const auto t0 = std::chrono::steady_clock::now();
  auto elapsed = [&] {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  };
  const bool trace = std::getenv("MOCAP_INDEX_TRACE") != nullptr;
  auto phase = [&](const char* what) {
    if (trace) std::fprintf(stderr, "mocap-index: %.3f s %s\n", elapsed(), what);
  };
  if (opt.out.empty()) throw InputError("<build>", 0, "no output file given");
  if (!(opt.transition_time_s > 0.0))
    throw InputError("<build>", 0, "transition time must be positive");
  if (opt.deflate_level < 0 || opt.deflate_level > 9)
    throw InputError("<build>", 0, "compression level must be 0..9");
  const fs::path out = fs::absolute(opt.out).lexically_normal();
  const std::size_t jobs = opt.jobs ? opt.jobs : std::max(1u, std::thread::hardware_concurrency());

  const Character character = opt.character ? read_character_file(*opt.character) : Character{};
  const EnergyParams energy{};
  RootAttributes attrs;
  attrs.build_tool = opt.tool_version;
  attrs.character_json = character_json(character);
  attrs.character_name = character.name;
  attrs.character_total_mass_kg = character.total_mass_kg;
  attrs.transition_time_s = opt.transition_time_s;
  attrs.unit_option = opt.unit ? unit_name(*opt.unit) : "auto";
  attrs.deflate_level = opt.deflate_level;
  attrs.energy = energy;

  // Inputs, absolute and sorted by the path stored in the index.
  const Collection col = list_collection(opt.inputs);
  std::vector<FileEntry> files;
  {
    std::set<std::string> seen;
    for (const auto& e : col.files) {
      std::string p = fs::absolute(e.path).lexically_normal().string();
      if (seen.insert(p).second)
        files.push_back(
            FileEntry{std::move(p), {}, false, {}, Plan::parse, 0, nullptr, nullptr, {}});
    }
    std::sort(files.begin(), files.end(),
              [](const FileEntry& a, const FileEntry& b) { return a.path < b.path; });
  }
  if (opt.strict && !col.problems.empty())
    throw InputError(col.problems.front().input, 0, col.problems.front().reason);

  IndexBuildSummary sum;
  sum.out = out;

  // The previous index, when its clips can be reused.
  std::unique_ptr<PreviousIndex> prev;
  std::error_code ec;
  if (!opt.full && fs::exists(out, ec)) {
    try {
      Index old = Index::open(out);
      const IndexInfo& oi = old.info();
      if (oi.build_tool != attrs.build_tool)
        sum.previous_index_note = "built by " + oi.build_tool + ": everything re-parsed";
      else if (oi.character_json != attrs.character_json || oi.unit_option != attrs.unit_option ||
               oi.transition_time_s != attrs.transition_time_s ||
               oi.energy_params.gravity_mps2 != energy.gravity_mps2 ||
               oi.energy_params.contact_height_m != energy.contact_height_m ||
               oi.energy_params.contact_speed_mps != energy.contact_speed_mps ||
               oi.energy_params.ground_height_m != energy.ground_height_m ||
               oi.energy_params.friction_coefficient != energy.friction_coefficient ||
               oi.energy_params.contact_patch_radius_m != energy.contact_patch_radius_m)
        sum.previous_index_note =
            "build parameters changed (character, unit or transition time): everything re-parsed";
      else
        prev = std::make_unique<PreviousIndex>(out, std::move(old));
    } catch (const InputError& e) {
      sum.previous_index_note =
          std::string("existing index not reusable (") + e.detail() + "): everything re-parsed";
    }
  }

  // Plan: stat every file; with a previous index, hash the candidates for reuse.
  std::unordered_map<std::string, const IndexClip*> old_clips;
  std::unordered_map<std::string, const IndexSkippedFile*> old_skips;
  std::unordered_map<std::string, std::pair<std::int64_t, std::uint64_t>> old_skip_stat;
  if (prev) {
    for (const auto& c : prev->index().clips()) old_clips.emplace(c.path, &c);
    for (const auto& s : prev->index().skipped()) old_skips.emplace(s.path, &s);
  }
  // Skipped-file stats of the previous index (for still-bad files).
  std::vector<std::pair<std::int64_t, std::uint64_t>> prev_skip_stats;
  if (prev) {
    std::lock_guard lib(h5::library_mutex());
    const h5::File f = h5::File::open(out);
    const h5::Group sk = f.root().open_group("skipped");
    const auto sizes = sk.open_dataset("size_bytes").read_all<std::uint64_t>();
    const auto mtimes = sk.open_dataset("mtime_ns").read_all<std::int64_t>();
    const auto& sv = prev->index().skipped();
    for (std::size_t i = 0; i < sv.size() && i < sizes.size() && i < mtimes.size(); ++i)
      old_skip_stat[sv[i].path] = {mtimes[i], sizes[i]};
  }

  // More threads than cores only adds contention (and a TBB warning).
  const std::size_t hw = std::max(1u, std::thread::hardware_concurrency());
  tbb::task_arena arena(static_cast<int>(std::min(jobs, hw)));
  arena.execute([&] {
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, files.size(), 4),
                      [&](const tbb::blocked_range<std::size_t>& r) {
                        for (std::size_t i = r.begin(); i != r.end(); ++i) {
                          FileEntry& f = files[i];
                          try {
                            f.stat = stat_file(f.path);
                            f.stat_ok = true;
                          } catch (const InputError& e) {
                            f.stat_error = e.detail();
                          }
                          f.labels = resolve_clip_labels(f.path);
                          if (!f.stat_ok) continue;
                          if (auto it = old_clips.find(f.path); it != old_clips.end()) {
                            f.old_clip = it->second;
                            if (f.old_clip->size_bytes == f.stat.size &&
                                f.old_clip->mtime_ns == f.stat.mtime_ns) {
                              // An unreadable file is parsed: that stage says why it fails.
                              try {
                                f.hash = hash_file(f.path);
                                if (f.hash == f.old_clip->content_hash) f.plan = Plan::reuse;
                              } catch (const InputError&) {
                              }
                            }
                          } else if (auto sk = old_skips.find(f.path); sk != old_skips.end()) {
                            f.old_skip = sk->second;
                            auto ss = old_skip_stat.find(f.path);
                            if (ss != old_skip_stat.end() && ss->second.first == f.stat.mtime_ns &&
                                ss->second.second == f.stat.size)
                              f.plan = Plan::still_bad;
                          }
                        }
                      });
  });

  phase("planned");
  const double planned_at = elapsed();
  // Nothing changed: keep the existing index as it is.
  if (prev) {
    std::set<std::string> now;
    bool all_same = true;
    for (const auto& f : files) {
      now.insert(f.path);
      if (f.plan == Plan::parse) all_same = false;
    }
    for (const auto& p : col.problems)
      if (!old_skips.count(p.input)) all_same = false;
    std::size_t removed = 0;
    for (const auto& c : prev->index().clips())
      if (!now.count(c.path)) ++removed;
    std::size_t skipped_missing = 0;
    for (const auto& s : prev->index().skipped())
      if (!now.count(s.path)) ++skipped_missing;
    if (removed || skipped_missing != col.problems.size()) all_same = false;
    // Labels are re-read every build: a changed sidecar changes the index.
    if (all_same) {
      const Index& old = prev->index();
      for (const auto& f : files) {
        if (f.plan != Plan::reuse) continue;
        std::vector<std::string> lab(old.label_keys().size());
        for (const auto& [k, v] : f.labels.labels) {
          const auto it = std::find(old.label_keys().begin(), old.label_keys().end(), k);
          if (it == old.label_keys().end()) {
            all_same = false;
            break;
          }
          lab[static_cast<std::size_t>(it - old.label_keys().begin())] = v;
        }
        if (lab != f.old_clip->labels || f.labels.source != f.old_clip->label_source)
          all_same = false;
        if (!all_same) break;
      }
    }
    if (all_same) {
      const Index& old = prev->index();
      sum.up_to_date = true;
      sum.clips = old.clips().size();
      sum.frames = old.frame_count();
      sum.skeletons = old.skeletons().size();
      sum.reused = sum.clips;
      sum.skipped = old.skipped();
      for (const auto& c : old.clips()) sum.source_bytes += c.size_bytes;
      sum.index_bytes = fs::file_size(out, ec);
      sum.seconds = elapsed();
      return sum;
    }
  }

  // The build proper.
  AtomicFile tmp(out);
  std::unique_ptr<IndexWriter> writer;
  {
    std::lock_guard lib(h5::library_mutex());
    writer = std::make_unique<IndexWriter>(tmp.temporary_path(), opt.deflate_level);
  }

  std::vector<IndexClip> clips;
  std::vector<ClipLabels> clip_labels;
  std::vector<IndexSkippedFile> skipped;
  std::vector<std::pair<std::int64_t, std::uint64_t>> skipped_stat;
  for (const auto& p : col.problems) {
    skipped.push_back({p.input, p.reason});
    skipped_stat.emplace_back(0, 0);
  }
  IndexBuildProgress progress;
  progress.files_total = files.size();
  if (opt.progress) opt.progress(progress);

  std::size_t next = 0;
  const std::size_t tokens = 2 * jobs + 2;
  // Stage timings (nanoseconds; worker stages summed over threads).
  using Clock = std::chrono::steady_clock;
  auto ns_since = [](Clock::time_point t) {
    return static_cast<std::int64_t>(
        std::chrono::duration_cast<std::chrono::nanoseconds>(Clock::now() - t).count());
  };
  std::atomic<std::int64_t> read_ns{0}, parse_ns{0}, dynamics_ns{0};
  std::int64_t write_ns = 0;
  // First error of the writing stage (--strict failures, HDF5 errors):
  // rethrown once the pipeline has drained.
  std::exception_ptr writer_failure;
  std::atomic<bool> writer_failed{false};
  arena.execute([&] {
    tbb::parallel_pipeline(
        tokens,
        tbb::make_filter<void, std::size_t>(tbb::filter_mode::serial_in_order,
                                            [&](tbb::flow_control& fc) -> std::size_t {
                                              if (writer_failed.load() || next >= files.size()) {
                                                fc.stop();
                                                return 0;
                                              }
                                              return next++;
                                            }) &
            tbb::make_filter<std::size_t, std::shared_ptr<Work>>(
                tbb::filter_mode::parallel,
                [&](std::size_t i) {
                  auto w = std::make_shared<Work>();
                  w->file = i;
                  const FileEntry& f = files[i];
                  if (f.plan != Plan::parse) return w;
                  if (!f.stat_ok) {
                    w->reason = "cannot stat: " + f.stat_error;
                    return w;
                  }
                  if (f.stat.size == 0) {
                    w->reason = "empty file";
                    return w;
                  }
                  auto t = Clock::now();
                  try {
                    IndexClip& c = w->clip;
                    RawClip raw;
                    {
                      const FileBytes text = read_file_bytes(f.path, f.stat.size);
                      read_ns += ns_since(t);
                      t = Clock::now();
                      c.content_hash = xxh64(text.view().data(), text.size());
                      raw = parse_bvh(text.view(), f.path);
                    }
                    if (raw.frame_count == 0) throw InputError(f.path, 0, "the clip has no frames");
                    const LengthUnit unit = opt.unit ? *opt.unit : detect_unit(raw);
                    parse_ns += ns_since(t);
                    t = Clock::now();
                    c.unit = unit_name(unit);
                    c.unit_scale_m = unit_scale_m(unit);
                    c.frame_time_s = raw.frame_time_s;
                    w->skeleton = std::make_unique<IndexedSkeleton>(
                        index_skeleton(raw, c.unit_scale_m, character, energy));
                    w->data = compute_clip_frame_data(raw, *w->skeleton, opt.transition_time_s);
                    dynamics_ns += ns_since(t);
                    w->ok = true;
                  } catch (const InputError& e) {
                    w->reason = failure_reason(e);
                  } catch (const std::exception& e) {
                    w->reason = std::string("cannot index: ") + e.what();
                  }
                  return w;
                }) &
            tbb::make_filter<std::shared_ptr<Work>, void>(
                tbb::filter_mode::serial_in_order, [&](std::shared_ptr<Work> w) {
                  // After a failure the remaining items only drain: an
                  // exception thrown out of a filter would cancel the pipeline
                  // and leak the items in flight (oneTBB does not destroy them).
                  if (writer_failure) return;
                  const auto t_write = Clock::now();
                  try {
                    FileEntry& f = files[w->file];
                    std::lock_guard lib(h5::library_mutex());
                    if (f.plan == Plan::reuse) {
                      IndexClip c = *f.old_clip;
                      c.skeleton =
                          writer->slot_for(prev->index().skeletons()[f.old_clip->skeleton]);
                      c.status = ClipStatus::reused;
                      c.label_source = f.labels.source;
                      writer->copy(c, clips.size(), *prev, *f.old_clip);
                      clips.push_back(std::move(c));
                      clip_labels.push_back(f.labels);
                      ++sum.reused;
                    } else if (f.plan == Plan::still_bad) {
                      if (opt.strict) throw InputError(f.path, 0, f.old_skip->reason);
                      skipped.push_back({f.path, f.old_skip->reason});
                      skipped_stat.emplace_back(f.stat.mtime_ns, f.stat.size);
                    } else if (!w->ok) {
                      if (opt.strict) throw InputError(f.path, 0, w->reason);
                      skipped.push_back({f.path, w->reason});
                      skipped_stat.emplace_back(f.stat.mtime_ns, f.stat.size);
                    } else {
                      IndexClip& c = w->clip;
                      c.path = f.path;
                      c.size_bytes = f.stat.size;
                      c.mtime_ns = f.stat.mtime_ns;
                      c.status = f.old_clip ? ClipStatus::parsed_changed : ClipStatus::parsed_new;
                      c.label_source = f.labels.source;
                      c.skeleton = writer->slot_for(to_table(*w->skeleton));
                      writer->append(c, clips.size(), w->data);
                      (f.old_clip ? sum.parsed_changed : sum.parsed_new) += 1;
                      clips.push_back(std::move(c));
                      clip_labels.push_back(f.labels);
                    }
                    ++progress.files_done;
                    if (!clips.empty() && clips.back().path == f.path) {
                      progress.frames_done += clips.back().frame_count;
                      progress.bytes_done += clips.back().size_bytes;
                    }
                    progress.elapsed_s = elapsed();
                    progress.current = f.path;
                    if (opt.progress) opt.progress(progress);
                  } catch (...) {
                    writer_failure = std::current_exception();
                    writer_failed.store(true);
                  }
                  write_ns += ns_since(t_write);
                }));
  });
  if (writer_failure) std::rethrow_exception(writer_failure);

  phase("pipeline done");
  const double pipeline_done_at = elapsed();
  sum.stages.plan_s = planned_at;
  sum.stages.read_s = 1e-9 * static_cast<double>(read_ns.load());
  sum.stages.parse_s = 1e-9 * static_cast<double>(parse_ns.load());
  sum.stages.dynamics_s = 1e-9 * static_cast<double>(dynamics_ns.load());
  sum.stages.write_s = 1e-9 * static_cast<double>(write_ns);
  if (clips.empty()) {
    std::string why = "no clip could be indexed";
    if (!skipped.empty())
      why += " (first problem: " + skipped.front().path + ": " + skipped.front().reason + ")";
    throw InputError(opt.inputs.empty() ? "<build>" : opt.inputs.front(), 0, why);
  }

  // Label keys: the union over clips, sorted.
  std::set<std::string> key_set;
  for (const auto& l : clip_labels)
    for (const auto& kv : l.labels) key_set.insert(kv.first);
  const std::vector<std::string> keys(key_set.begin(), key_set.end());
  for (std::size_t c = 0; c < clips.size(); ++c) {
    clips[c].labels.assign(keys.size(), std::string());
    for (const auto& [k, v] : clip_labels[c].labels)
      clips[c].labels[static_cast<std::size_t>(std::lower_bound(keys.begin(), keys.end(), k) -
                                               keys.begin())] = v;
  }

  {
    std::lock_guard lib(h5::library_mutex());
    sum.skeletons = writer->skeleton_count();
    writer->finish(clips, keys, skipped, skipped_stat, attrs);
    writer.reset();
  }
  prev.reset();  // closes the previous index before it is replaced (takes the library lock itself)
  phase("written");
  seal_index_file(tmp.temporary_path());
  phase("sealed");
  // Checked before it replaces anything: user block, tag, version, tables.
  // (The whole-file hash was just computed from the file by seal_index_file.)
  Index::open(tmp.temporary_path());
  phase("checked");
  tmp.commit();
  phase("synced");

  std::set<std::string> now;
  for (const auto& c : clips) now.insert(c.path);
  sum.clips = clips.size();
  for (const auto& c : clips) {
    sum.frames += c.frame_count;
    sum.source_bytes += c.size_bytes;
  }
  if (!old_clips.empty())
    for (const auto& [path, c] : old_clips)
      if (!now.count(path)) ++sum.removed;
  sum.skipped = std::move(skipped);
  sum.index_bytes = fs::file_size(out, ec);
  sum.seconds = elapsed();
  sum.stages.finalize_s = sum.seconds - pipeline_done_at;
  return sum;
}

}  // namespace mocap
