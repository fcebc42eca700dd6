// The index writer (index_writer.hpp): appendable columns with running
// checksums, the skeleton tables, and the record tables and root attributes
// walked from mocap/common/io/index_tables.hpp.
#include "index_writer.hpp"

#include <algorithm>
#include <array>
#include <ctime>
#include <span>
#include <string_view>
#include <type_traits>
#include <variant>

#include "mocap/common/io/index_tables.hpp"
#include "mocap/common/util/xxh64.hpp"

namespace mocap {

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

/// Every column of a record table (index_tables.hpp), one row per record.
template <class Record>
void write_table(h5::Group& g, std::span<const IndexColumn<Record>> columns,
                 const std::vector<Record>& records) {
  for (const IndexColumn<Record>& column : columns)
    std::visit(
        [&](auto member) {
          using T = std::remove_cvref_t<decltype(std::declval<const Record&>().*member)>;
          if constexpr (std::is_same_v<T, std::string>) {
            std::vector<std::string> values;
            for (const Record& r : records) values.push_back(r.*member);
            put_strings(g, column.name, {values.size()}, values, column.description);
          } else if constexpr (std::is_enum_v<T>) {
            std::vector<std::uint8_t> values;
            for (const Record& r : records) values.push_back(static_cast<std::uint8_t>(r.*member));
            put_enum(g, column.name, values, index_enum_members(T{}), column.description);
          } else {
            std::vector<T> values;
            for (const Record& r : records) values.push_back(r.*member);
            put(g, column.name, {values.size()}, values, column.unit, column.description);
          }
        },
        column.member);
}

/// The root attributes (kIndexAttributes) from `info`.
void write_root_attributes(h5::Group& root, const IndexInfo& info) {
  for (const IndexAttribute& a : kIndexAttributes)
    std::visit(
        [&](auto value) {
          using V = decltype(value);
          if constexpr (std::is_same_v<V, const char*>) {
            root.set_attribute(a.name, value);
          } else if constexpr (std::is_same_v<V, double EnergyParams::*>) {
            root.set_attribute(a.name, info.energy_params.*value);
          } else {
            const auto& field = info.*value;
            using T = std::remove_cvref_t<decltype(field)>;
            if constexpr (std::is_same_v<T, std::string> || std::is_same_v<T, double>)
              root.set_attribute(a.name, field);
            else if constexpr (std::is_same_v<T, std::vector<double>>)
              root.set_attribute(a.name, std::span<const double>(field));
            else
              root.set_attribute(a.name, static_cast<std::int64_t>(field));
          }
        },
        a.value);
}

std::string utc_now() {
  const std::time_t t = std::time(nullptr);
  std::tm tm{};
  gmtime_r(&t, &tm);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%SZ", &tm);
  return buf;
}

}  // namespace

/// One skeleton's group and its appendable columns.
struct IndexWriterSlot {
  IndexSkeleton table;
  h5::Group group;
  std::array<Column, kFrameFieldCount> frames;
  std::array<std::array<Column, kBlockFieldCount>, kIndexBlockSizes.size()> blocks;
  std::array<Column, kClipBoundFieldCount> bounds;
};

namespace {

/// The skeleton table of a slot: its columns' attributes, the group's
/// attributes and datasets (docs/index-format.md "/skeletons/<k>").
void write_skeleton_table(IndexWriterSlot& s) {
  for (auto& c : s.frames)
    if (c.spec) c.finish();  // derived fields have no column
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

}  // namespace

PreviousIndex::PreviousIndex(const std::filesystem::path& path, Index index)
    : index_(std::move(index)), file_(h5::File::open(path)) {}

const h5::Dataset& PreviousIndex::dataset(std::uint32_t skeleton, const std::string& group,
                                          const char* field) {
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

IndexWriter::IndexWriter(const std::filesystem::path& path, int deflate_level)
    : file_(h5::File::create(path, kIndexUserBlockBytes)), deflate_(deflate_level) {
  skeletons_ = file_.root().create_group("skeletons");
}

IndexWriter::~IndexWriter() = default;

std::uint32_t IndexWriter::slot_for(const IndexSkeleton& s) {
  if (auto it = by_id_.find(s.id); it != by_id_.end()) return it->second;
  const auto k = static_cast<std::uint32_t>(slots_.size());
  auto slot = std::make_unique<IndexWriterSlot>();
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
    if (frame_field_stored(kFrameFields[i].name, kIndexSchemaVersion))
      make(frames, slot->frames[i], kFrameFields[i], deflate_);
  // Bounds as the frame arrays (--compress): deflated, they were 16 % smaller
  // and their compression in the one writer thread took a sixth of a 2-job
  // build of set 2 (docs/performance.md "Storing less").
  for (std::size_t b = 0; b < kIndexBlockSizes.size(); ++b) {
    h5::Group g = slot->group.create_group("blocks" + std::to_string(kIndexBlockSizes[b]));
    for (std::size_t i = 0; i < kBlockFieldCount; ++i)
      make(g, slot->blocks[b][i], kBlockFields[i], deflate_);
  }
  h5::Group cb = slot->group.create_group("clip_bounds");
  for (std::size_t i = 0; i < kClipBoundFieldCount; ++i)
    make(cb, slot->bounds[i], kClipBoundFields[i], deflate_);
  slots_.push_back(std::move(slot));
  by_id_.emplace(s.id, k);
  return k;
}

void IndexWriter::append(IndexClip& clip, std::size_t clip_index, const ClipFrameData& d) {
  IndexWriterSlot& s = place(clip, clip_index, d.frame_count);
  for (std::size_t i = 0; i < kFrameFieldCount; ++i) {
    if (!s.frames[i].spec) continue;  // derived on load, not stored
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

void IndexWriter::copy(IndexClip& clip, std::size_t clip_index, PreviousIndex& prev,
                       const IndexClip& old) {
  IndexWriterSlot& s = place(clip, clip_index, old.frame_count);
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
  for (auto& c : s.frames)
    if (c.spec) copy_rows(c, "frames", old.frame_start, old.frame_count);
  for (std::size_t b = 0; b < kIndexBlockSizes.size(); ++b) {
    const std::size_t bs = kIndexBlockSizes[b];
    const std::uint64_t first = b == 0 ? old.block16_start : old.block64_start;
    for (auto& c : s.blocks[b])
      copy_rows(c, "blocks" + std::to_string(bs), first, (old.frame_count + bs - 1) / bs);
  }
  for (auto& c : s.bounds) copy_rows(c, "clip_bounds", old.row, 1);
}

void IndexWriter::finish(const std::vector<IndexClip>& clips,
                         const std::vector<std::string>& label_keys,
                         const std::vector<IndexSkippedFile>& skipped, IndexInfo info) {
  for (auto& slot : slots_) write_skeleton_table(*slot);

  h5::Group clip_group = file_.root().create_group("clips");
  write_table<IndexClip>(clip_group, kClipColumns, clips);
  std::vector<std::string> labels;
  for (const IndexClip& c : clips) labels.insert(labels.end(), c.labels.begin(), c.labels.end());
  put_strings(clip_group, "label_keys", {label_keys.size()}, label_keys, kLabelKeysDescription);
  put_strings(clip_group, "labels", {clips.size(), label_keys.size()}, labels, kLabelsDescription);

  h5::Group skipped_group = file_.root().create_group("skipped");
  write_table<IndexSkippedFile>(skipped_group, kSkippedColumns, skipped);

  info.build_time_utc = utc_now();
  info.clip_count = clips.size();
  info.frame_count = 0;
  for (const IndexClip& c : clips) info.frame_count += c.frame_count;
  info.skeleton_count = slots_.size();
  info.skipped_count = skipped.size();
  write_root_attributes(file_.root(), info);
  slots_.clear();
  skeletons_ = h5::Group();
  file_.close();
}

IndexWriterSlot& IndexWriter::place(IndexClip& clip, std::size_t clip_index,
                                    std::uint64_t frame_count) {
  IndexWriterSlot& s = *slots_.at(clip.skeleton);
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

}  // namespace mocap
