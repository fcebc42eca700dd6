// Runtime reader of the HDF5 index (mocap/common/io/index.hpp, docs/index-format.md).
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <map>
#include <mutex>
#include <optional>
#include <sstream>
#include <tuple>
#include <type_traits>
#include <variant>

#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include "io/index_checksum.hpp"
#include "mocap/common/dynamics/index_frames.hpp"
#include "mocap/common/io/hdf5.hpp"
#include "mocap/common/io/index.hpp"
#include "mocap/common/io/index_tables.hpp"
#include "mocap/common/util/error.hpp"
#include "mocap/common/util/file.hpp"
#include "mocap/common/util/xxh64.hpp"

namespace mocap {

namespace fs = std::filesystem;

// ---------------------------------------------------------------------------
// Reading helpers

namespace {

template <class T>
std::vector<T> read_column(const h5::Group& g, const std::string& name, std::size_t rows,
                           const std::vector<std::size_t>& row_shape = {}) {
  const h5::Dataset d = g.open_dataset(name);
  const auto shape = d.shape();
  std::vector<hsize_t> want{rows};
  for (auto s : row_shape) want.push_back(s);
  if (shape != want) {
    std::string s;
    for (auto v : shape) s += (s.empty() ? "" : ", ") + std::to_string(v);
    std::string w;
    for (auto v : want) w += (w.empty() ? "" : ", ") + std::to_string(v);
    throw InputError(d.file(), 0, d.path() + ": shape [" + s + "], expected [" + w + "]");
  }
  return d.read_all<T>();
}

std::vector<std::string> read_string_column(const h5::Group& g, const std::string& name,
                                            std::size_t rows, std::size_t per_row = 1) {
  const h5::Dataset d = g.open_dataset(name);
  auto v = d.read_strings();
  if (v.size() != rows * per_row)
    throw InputError(d.file(), 0,
                     d.path() + ": " + std::to_string(v.size()) + " strings, expected " +
                         std::to_string(rows * per_row));
  return v;
}

/// Column `column` of a record table into records[r].*member for every row r
/// (records has the table's row count).
template <class Record>
void read_column_into(const h5::Group& g, const IndexColumn<Record>& column,
                      std::vector<Record>& records) {
  const std::size_t rows = records.size();
  std::visit(
      [&](auto member) {
        using T = std::remove_reference_t<decltype(records.front().*member)>;
        if constexpr (std::is_same_v<T, std::string>) {
          auto values = read_string_column(g, column.name, rows);
          for (std::size_t r = 0; r < rows; ++r) records[r].*member = std::move(values[r]);
        } else if constexpr (std::is_enum_v<T>) {
          const h5::Dataset d = g.open_dataset(column.name);
          const auto values = d.read_enum();
          if (values.size() != rows)
            throw InputError(d.file(), 0,
                             d.path() + ": " + std::to_string(values.size()) +
                                 " values, expected " + std::to_string(rows));
          const std::size_t members = index_enum_members(T{}).size();
          for (std::size_t r = 0; r < rows; ++r) {
            if (values[r] >= members)
              throw InputError(d.file(), 0,
                               d.path() + ": bad value " + std::to_string(values[r]) + " in row " +
                                   std::to_string(r));
            records[r].*member = static_cast<T>(values[r]);
          }
        } else {
          const auto values = read_column<T>(g, column.name, rows);
          for (std::size_t r = 0; r < rows; ++r) records[r].*member = values[r];
        }
      },
      column.member);
}

/// Every column of a record table (index_tables.hpp).
template <class Record>
void read_table(const h5::Group& g, std::span<const IndexColumn<Record>> columns,
                std::vector<Record>& records) {
  for (const IndexColumn<Record>& column : columns) read_column_into(g, column, records);
}

/// The root attributes (kIndexAttributes); fixed texts must be present.
IndexInfo read_root_attributes(const h5::Group& root) {
  IndexInfo info;
  for (const IndexAttribute& a : kIndexAttributes)
    std::visit(
        [&](auto value) {
          using V = decltype(value);
          if constexpr (std::is_same_v<V, const char*>) {
            root.string_attribute(a.name);
          } else if constexpr (std::is_same_v<V, double EnergyParams::*>) {
            info.energy_params.*value = root.double_attribute(a.name);
          } else {
            auto& field = info.*value;
            using T = std::remove_reference_t<decltype(field)>;
            if constexpr (std::is_same_v<T, std::string>)
              field = root.string_attribute(a.name);
            else if constexpr (std::is_same_v<T, double>)
              field = root.double_attribute(a.name);
            else if constexpr (std::is_same_v<T, std::vector<double>>)
              field = root.doubles_attribute(a.name);
            else
              field = static_cast<T>(root.int_attribute(a.name));
          }
        },
        a.value);
  return info;
}

std::optional<Channel> parse_channel(const std::string& s) {
  static const char* names[] = {"Xposition", "Yposition", "Zposition",
                                "Xrotation", "Yrotation", "Zrotation"};
  for (int i = 0; i < 6; ++i)
    if (s == names[i]) return static_cast<Channel>(i);
  return std::nullopt;
}

}  // namespace

// ---------------------------------------------------------------------------
// Index

struct Index::Impl {
  fs::path path;
  h5::File file;
  IndexInfo info;
  std::vector<IndexClip> clips;
  std::vector<std::string> label_keys;
  std::vector<IndexSkeleton> skeletons;
  std::vector<IndexSkippedFile> skipped;
  std::uint64_t frames = 0;
  mutable std::mutex mutex;
  mutable std::map<std::tuple<std::uint32_t, std::string, std::string>, std::unique_ptr<IndexArray>>
      arrays;
};

Index::Index(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
Index::Index(Index&&) noexcept = default;
Index& Index::operator=(Index&&) noexcept = default;
Index::~Index() {
  if (impl_) {
    std::lock_guard lock(h5::library_mutex());
    impl_.reset();
  }
}

const fs::path& Index::path() const {
  return impl_->path;
}
const IndexInfo& Index::info() const {
  return impl_->info;
}
const std::vector<IndexClip>& Index::clips() const {
  return impl_->clips;
}
const std::vector<std::string>& Index::label_keys() const {
  return impl_->label_keys;
}
const std::vector<IndexSkeleton>& Index::skeletons() const {
  return impl_->skeletons;
}
const std::vector<IndexSkippedFile>& Index::skipped() const {
  return impl_->skipped;
}
std::uint64_t Index::frame_count() const {
  return impl_->frames;
}

std::string Index::label(std::size_t c, std::string_view key) const {
  const auto& keys = impl_->label_keys;
  for (std::size_t k = 0; k < keys.size(); ++k)
    if (keys[k] == key) return impl_->clips.at(c).labels[k];
  return {};
}

namespace {

IndexSkeleton read_skeleton(const h5::Group& g, const std::string& file) {
  IndexSkeleton s;
  const std::string id_hex = g.string_attribute("id");
  try {
    s.id = std::stoull(id_hex, nullptr, 16);
  } catch (const std::exception&) {
    throw InputError(file, 0, g.path() + ": attribute id is not a hexadecimal number");
  }
  const auto joints_i = g.int_attribute("joint_count");
  if (joints_i <= 0 || joints_i > 100000) throw InputError(file, 0, g.path() + ": bad joint_count");
  const auto J = static_cast<std::size_t>(joints_i);
  s.root_joint = static_cast<int>(g.int_attribute("root_joint"));
  if (s.root_joint < 0 || static_cast<std::size_t>(s.root_joint) >= J)
    throw InputError(file, 0, g.path() + ": root_joint out of range");
  s.frame_count = static_cast<std::uint64_t>(g.int_attribute("frame_count"));
  s.block16_count = static_cast<std::uint64_t>(g.int_attribute("block16_count"));
  s.block64_count = static_cast<std::uint64_t>(g.int_attribute("block64_count"));

  Skeleton& k = s.skeleton;
  k.names = read_string_column(g, "names", J);
  k.parents = read_column<std::int32_t>(g, "parents", J);
  const auto offsets = read_column<double>(g, "offsets_m", J, {3});
  const auto ends = read_column<double>(g, "end_sites_m", J, {3});
  k.has_end_site = read_column<std::uint8_t>(g, "has_end_site", J);
  k.translation_scales = read_column<double>(g, "translation_scales", J);
  s.channels = read_string_column(g, "channels", J);
  k.unit_scale_m = g.double_attribute("unit_scale_m");
  std::size_t column = 0;
  for (std::size_t j = 0; j < J; ++j) {
    if (k.parents[j] >= static_cast<int>(j) || k.parents[j] < -1)
      throw InputError(
          file, 0, g.path() + "/parents: joint " + std::to_string(j) + " comes before its parent");
    k.offsets_m.emplace_back(offsets[3 * j], offsets[3 * j + 1], offsets[3 * j + 2]);
    k.end_sites_m.emplace_back(ends[3 * j], ends[3 * j + 1], ends[3 * j + 2]);
    JointChannelMap m;
    std::istringstream in(s.channels[j]);
    std::string tok;
    while (in >> tok) {
      const auto ch = parse_channel(tok);
      if (!ch) throw InputError(file, 0, g.path() + "/channels: unknown channel '" + tok + "'");
      const int axis = channel_axis(*ch);
      if (channel_is_rotation(*ch)) {
        if (m.rotation_count >= 3)
          throw InputError(file, 0, g.path() + "/channels: more than 3 rotations");
        m.rotation_column[m.rotation_count] = static_cast<int>(column);
        m.rotation_axis[m.rotation_count] = static_cast<std::uint8_t>(axis);
        ++m.rotation_count;
      } else {
        m.position_column[axis] = static_cast<int>(column);
      }
      ++column;
    }
    k.channels.push_back(m);
  }
  k.channel_count = column;

  const auto classes = read_string_column(g, "segment_class", J);
  const auto sides = read_string_column(g, "segment_side", J);
  const auto mass = read_column<double>(g, "mass_kg", J);
  const auto com = read_column<double>(g, "com_local_m", J, {3});
  const auto tip = read_column<double>(g, "tip_local_m", J, {3});
  const auto inertia = read_column<double>(g, "inertia_local_kgm2", J, {3, 3});
  const auto length = read_column<double>(g, "segment_length_m", J);
  s.body.segments.resize(J);
  s.body.total_mass_kg = 0.0;
  for (std::size_t j = 0; j < J; ++j) {
    Segment& seg = s.body.segments[j];
    seg.joint = static_cast<int>(j);
    const auto cls = parse_segment_class(classes[j]);
    if (!cls)
      throw InputError(file, 0, g.path() + "/segment_class: unknown class '" + classes[j] + "'");
    seg.cls = *cls;
    if (sides[j] == "left")
      seg.side = Side::left;
    else if (sides[j] == "right")
      seg.side = Side::right;
    else if (sides[j] == "center")
      seg.side = Side::center;
    else
      throw InputError(file, 0, g.path() + "/segment_side: unknown side '" + sides[j] + "'");
    seg.mass_kg = mass[j];
    seg.com_local_m = Eigen::Vector3d(com[3 * j], com[3 * j + 1], com[3 * j + 2]);
    seg.tip_local_m = Eigen::Vector3d(tip[3 * j], tip[3 * j + 1], tip[3 * j + 2]);
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c)
        seg.inertia_local_kgm2(r, c) =
            inertia[9 * j + 3 * static_cast<std::size_t>(r) + static_cast<std::size_t>(c)];
    seg.length_m = length[j];
    s.body.total_mass_kg += seg.mass_kg;
  }
  const auto S = static_cast<std::size_t>(g.int_attribute("segment_count"));
  if (S > J) throw InputError(file, 0, g.path() + ": segment_count exceeds joint_count");
  s.segments = read_column<std::int32_t>(g, "segments", S);
  for (std::size_t i = 0; i < S; ++i)
    if (s.segments[i] < 0 || static_cast<std::size_t>(s.segments[i]) >= J ||
        (i > 0 && s.segments[i] <= s.segments[i - 1]))
      throw InputError(file, 0,
                       g.path() + "/segments: joint indices must be increasing and in range");
  return s;
}

}  // namespace

Index Index::open(const fs::path& path, const IndexOpenOptions& options) {
  auto impl = std::make_unique<Impl>();
  impl->path = path;
  const std::string file = path.string();
  check_index_file(path, options.verify_file_checksum);
  std::lock_guard lock(h5::library_mutex());
  impl->file = h5::File::open(path);
  const h5::Group& root = impl->file.root();

  // Tag and version first: nothing else is read from a file of another version.
  if (!root.has_attribute("format") || root.string_attribute("format") != kIndexFormat)
    throw InputError(
        file, 0,
        "not a mocap index (root attribute format is not '" + std::string(kIndexFormat) + "')");
  const std::int64_t version = root.int_attribute("schema_version");
  if (version < kIndexOldestSchemaVersion || version > kIndexSchemaVersion)
    throw InputError(file, 0,
                     "unsupported index schema version " + std::to_string(version) +
                         " (this build reads " + std::to_string(kIndexOldestSchemaVersion) +
                         " to " + std::to_string(kIndexSchemaVersion) +
                         "); rebuild the index with this mocap-index");

  impl->info = read_root_attributes(root);
  const IndexInfo& info = impl->info;

  // Skeletons.
  const h5::Group skel_group = root.open_group("skeletons");
  const auto skeleton_count = static_cast<std::size_t>(info.skeleton_count);
  for (std::size_t k = 0; k < skeleton_count; ++k) {
    const h5::Group g = skel_group.open_group(std::to_string(k));
    // The small tables (names, parents, offsets, channels, masses, inertia):
    // a flipped bit there would change answers silently. The per-frame and
    // bound arrays are checked when read (array, stream_rows).
    check_group_checksums(g);
    impl->skeletons.push_back(read_skeleton(g, file));
  }
  if (skel_group.members().size() != skeleton_count)
    throw InputError(file, 0,
                     "/skeletons: " + std::to_string(skel_group.members().size()) +
                         " groups, root attribute skeleton_count says " +
                         std::to_string(skeleton_count));

  // Clips.
  const h5::Group cg = root.open_group("clips");
  check_group_checksums(cg);  // paths, labels, frame ranges, frame times
  const std::size_t C = static_cast<std::size_t>(info.clip_count);
  impl->clips.resize(C);
  read_table<IndexClip>(cg, kClipColumns, impl->clips);
  impl->label_keys = cg.open_dataset("label_keys").read_strings();
  const std::size_t K = impl->label_keys.size();
  const auto labels = K ? read_string_column(cg, "labels", C, K) : std::vector<std::string>{};

  std::vector<std::uint64_t> next_frame(skeleton_count, 0), next_b16(skeleton_count, 0),
      next_b64(skeleton_count, 0);
  for (std::size_t c = 0; c < C; ++c) {
    IndexClip& clip = impl->clips[c];
    clip.labels.assign(labels.begin() + static_cast<std::ptrdiff_t>(c * K),
                       labels.begin() + static_cast<std::ptrdiff_t>((c + 1) * K));
    const std::string where = "/clips row " + std::to_string(c) + " (" + clip.path + ")";
    if (c > 0 && !(impl->clips[c - 1].path < clip.path))
      throw InputError(file, 0, where + ": clips are not sorted by path");
    if (clip.skeleton >= skeleton_count)
      throw InputError(file, 0, where + ": skeleton out of range");
    IndexSkeleton& s = impl->skeletons[clip.skeleton];
    // Clips of a skeleton occupy consecutive rows, frames and blocks, in clip order.
    if (clip.row != s.clips.size() || clip.frame_start != next_frame[clip.skeleton] ||
        clip.block16_start != next_b16[clip.skeleton] ||
        clip.block64_start != next_b64[clip.skeleton])
      throw InputError(file, 0, where + ": row, frame or block ranges are not contiguous");
    if (clip.frame_count == 0) throw InputError(file, 0, where + ": clip has no frames");
    if (!(clip.frame_time_s > 0.0) || !std::isfinite(clip.frame_time_s))
      throw InputError(file, 0, where + ": frame_time_s must be positive");
    s.clips.push_back(c);
    next_frame[clip.skeleton] += clip.frame_count;
    next_b16[clip.skeleton] += (clip.frame_count + 15) / 16;
    next_b64[clip.skeleton] += (clip.frame_count + 63) / 64;
    impl->frames += clip.frame_count;
  }
  for (std::size_t k = 0; k < skeleton_count; ++k) {
    const IndexSkeleton& s = impl->skeletons[k];
    if (s.frame_count != next_frame[k] || s.block16_count != next_b16[k] ||
        s.block64_count != next_b64[k])
      throw InputError(
          file, 0,
          "/skeletons/" + std::to_string(k) + ": frame or block counts disagree with /clips");
  }
  if (impl->frames != info.frame_count)
    throw InputError(file, 0, "root attribute frame_count disagrees with /clips/frame_count");

  impl->skipped.resize(static_cast<std::size_t>(info.skipped_count));
  read_table<IndexSkippedFile>(root.open_group("skipped"), kSkippedColumns, impl->skipped);
  return Index(std::move(impl));
}

namespace {

struct ArraySpec {
  IndexFieldSpec spec;
  std::uint64_t rows = 0;
};

// The field spec and row count of array (skeleton, group, field); throws on unknown names.
ArraySpec array_spec(const fs::path& path, const std::vector<IndexSkeleton>& skeletons,
                     std::uint32_t skeleton, std::string_view group, std::string_view field) {
  std::span<const IndexFieldSpec> table;
  std::uint64_t rows = 0;
  if (skeleton >= skeletons.size())
    throw InputError(path.string(), 0, "skeleton " + std::to_string(skeleton) + " out of range");
  const IndexSkeleton& s = skeletons[skeleton];
  if (group == "frames") {
    table = kFrameFields;
    rows = s.frame_count;
  } else if (group == "blocks16") {
    table = kBlockFields;
    rows = s.block16_count;
  } else if (group == "blocks64") {
    table = kBlockFields;
    rows = s.block64_count;
  } else if (group == "clip_bounds") {
    table = kClipBoundFields;
    rows = s.clips.size();
  } else {
    throw InputError(path.string(), 0, "unknown array group '" + std::string(group) + "'");
  }
  const int fi = find_field(table, field);
  if (fi < 0)
    throw InputError(path.string(), 0,
                     "unknown field '" + std::string(field) + "' in " + std::string(group));
  return {table[static_cast<std::size_t>(fi)], rows};
}

// Opens the dataset of an array and checks its shape (library mutex held by the caller).
h5::Dataset open_array(const h5::File& file, const IndexSkeleton& s, std::uint32_t skeleton,
                       std::string_view group, std::string_view field, const ArraySpec& a) {
  h5::Dataset d = file.root()
                      .open_group("skeletons")
                      .open_group(std::to_string(skeleton))
                      .open_group(std::string(group))
                      .open_dataset(std::string(field));
  std::vector<hsize_t> want{a.rows};
  for (auto v : row_dims(a.spec.shape, s.skeleton.joint_count(), s.segments.size()))
    want.push_back(v);
  if (d.shape() != want)
    throw InputError(d.file(), 0, d.path() + ": shape does not match the clip table");
  return d;
}

}  // namespace

const IndexArray& Index::array(std::uint32_t skeleton, std::string_view group,
                               std::string_view field) const {
  const ArraySpec as = array_spec(impl_->path, impl_->skeletons, skeleton, group, field);
  const IndexFieldSpec& spec = as.spec;
  const IndexSkeleton& s = impl_->skeletons[skeleton];
  auto key = std::make_tuple(skeleton, std::string(group), std::string(field));

  if (group == "frames" && !frame_field_stored(field, impl_->info.schema_version)) {
    const std::array<std::string_view, 1> one{field};
    derive_arrays(skeleton, one);
    std::lock_guard own(impl_->mutex);
    return *impl_->arrays.at(key);
  }

  std::lock_guard own(impl_->mutex);
  if (auto it = impl_->arrays.find(key); it != impl_->arrays.end()) return *it->second;
  std::lock_guard lib(h5::library_mutex());
  const h5::Dataset d = open_array(impl_->file, s, skeleton, group, field, as);
  auto a = std::make_unique<IndexArray>();
  a->rows = as.rows;
  a->row_elements = row_elements(spec.shape, s.skeleton.joint_count(), s.segments.size());
  Xxh64 h;
  if (spec.dtype == IndexDType::f32) {
    a->f32 = d.read_all<float>();
    h.update(a->f32.data(), a->f32.size() * sizeof(float));
  } else {
    a->f64 = d.read_all<double>();
    h.update(a->f64.data(), a->f64.size() * sizeof(double));
  }
  if (hex64(h.digest()) != d.string_attribute("checksum_xxh64"))
    throw InputError(d.file(), 0, d.path() + ": checksum mismatch (the index is damaged)");
  const IndexArray& ref = *a;
  impl_->arrays.emplace(std::move(key), std::move(a));
  return ref;
}

std::vector<const IndexArray*> Index::arrays(std::uint32_t skeleton, std::string_view group,
                                             std::span<const std::string_view> fields) const {
  if (group == "frames") derive_arrays(skeleton, fields);
  std::vector<const IndexArray*> out;
  for (std::string_view f : fields) out.push_back(&array(skeleton, group, f));
  return out;
}

void Index::derive_arrays(std::uint32_t skeleton, std::span<const std::string_view> fields) const {
  const IndexSkeleton& s = impl_->skeletons[skeleton];
  std::vector<std::string_view> todo;
  std::vector<std::unique_ptr<IndexArray>> made;
  for (std::string_view field : fields) {
    const ArraySpec as = array_spec(impl_->path, impl_->skeletons, skeleton, "frames", field);
    if (frame_field_stored(field, impl_->info.schema_version) ||
        std::find(todo.begin(), todo.end(), field) != todo.end())
      continue;
    {
      std::lock_guard own(impl_->mutex);
      if (impl_->arrays.contains(
              std::make_tuple(skeleton, std::string("frames"), std::string(field))))
        continue;
    }
    auto a = std::make_unique<IndexArray>();
    a->rows = as.rows;
    a->row_elements = row_elements(as.spec.shape, s.skeleton.joint_count(), s.segments.size());
    a->f32.resize(a->rows * a->row_elements);
    todo.push_back(field);
    made.push_back(std::move(a));
  }
  if (todo.empty()) return;
  // Derived without the lock, streamed (nothing else is kept).
  stream_derived_rows(
      skeleton, todo, 8192,
      [&](std::uint64_t first, std::uint64_t count, std::span<const float* const> rows) {
        for (std::size_t i = 0; i < made.size(); ++i) {
          IndexArray& a = *made[i];
          std::copy_n(rows[i], count * a.row_elements, a.f32.data() + first * a.row_elements);
        }
      });
  std::lock_guard own(impl_->mutex);
  for (std::size_t i = 0; i < todo.size(); ++i)
    impl_->arrays.emplace(std::make_tuple(skeleton, std::string("frames"), std::string(todo[i])),
                          std::move(made[i]));
}

void Index::stream_rows(
    std::uint32_t skeleton, std::string_view group, std::string_view field,
    std::uint64_t rows_per_block,
    const std::function<void(std::uint64_t, std::uint64_t, const float*)>& fn) const {
  const ArraySpec as = array_spec(impl_->path, impl_->skeletons, skeleton, group, field);
  const IndexSkeleton& s = impl_->skeletons[skeleton];
  if (group == "frames" && !frame_field_stored(field, impl_->info.schema_version))
    return stream_derived_rows(skeleton, field, rows_per_block, fn);
  if (as.spec.dtype != IndexDType::f32)
    throw InputError(impl_->path.string(), 0,
                     "stream_rows: '" + std::string(field) + "' is not a float array");
  const std::size_t per_row =
      row_elements(as.spec.shape, s.skeleton.joint_count(), s.segments.size());
  rows_per_block = std::max<std::uint64_t>(rows_per_block, 1);
  std::optional<h5::Dataset> d;
  std::string expected, file, where;
  {
    std::lock_guard lib(h5::library_mutex());
    d.emplace(open_array(impl_->file, s, skeleton, group, field, as));
    expected = d->string_attribute("checksum_xxh64");
    file = d->file();
    where = d->path();
  }
  // The dataset closes under the library mutex, also when fn throws.
  struct Close {
    std::optional<h5::Dataset>& d;
    ~Close() {
      std::lock_guard lib(h5::library_mutex());
      d.reset();
    }
  } close{d};
  std::vector<float> buf;
  Xxh64 h;
  for (std::uint64_t r = 0; r < as.rows; r += rows_per_block) {
    const std::uint64_t n = std::min(rows_per_block, as.rows - r);
    buf.resize(static_cast<std::size_t>(n) * per_row);
    {
      std::lock_guard lib(h5::library_mutex());
      d->read_rows_into<float>(r, n, buf.data());
    }
    h.update(buf.data(), buf.size() * sizeof(float));
    fn(r, n, buf.data());
  }
  // The same message as array()'s.
  if (hex64(h.digest()) != expected)
    throw InputError(file, 0, where + ": checksum mismatch (the index is damaged)");
}

void Index::stream_derived_rows(
    std::uint32_t skeleton, std::string_view field, std::uint64_t rows_per_block,
    const std::function<void(std::uint64_t, std::uint64_t, const float*)>& fn) const {
  const std::array<std::string_view, 1> one{field};
  stream_derived_rows(skeleton, one, rows_per_block,
                      [&](std::uint64_t first, std::uint64_t count,
                          std::span<const float* const> rows) { fn(first, count, rows[0]); });
}

void Index::stream_derived_rows(
    std::uint32_t skeleton, std::span<const std::string_view> fields, std::uint64_t rows_per_block,
    const std::function<void(std::uint64_t, std::uint64_t, std::span<const float* const>)>& fn)
    const {
  const IndexSkeleton& s = impl_->skeletons[skeleton];
  const std::size_t J = s.skeleton.joint_count();
  std::vector<std::size_t> per_row;
  for (std::string_view field : fields) {
    const ArraySpec as = array_spec(impl_->path, impl_->skeletons, skeleton, "frames", field);
    per_row.push_back(row_elements(as.spec.shape, J, s.segments.size()));
  }
  const DynamicsModel model = dynamics_model(skeleton);
  const double transition_time_s = impl_->info.transition_time_s;
  // The stored sources, read in step, hashed as read.
  struct Source {
    const char* name = "";
    std::size_t per_row = 0;
    std::optional<h5::Dataset> d;
    std::string expected;
    std::vector<float> rows;
    Xxh64 hash;
  };
  std::array<Source, 2> src;
  src[0].name = "local_rotations";
  src[0].per_row = J * 4;
  src[1].name = "joint_positions_m";
  src[1].per_row = J * 3;
  {
    std::lock_guard lib(h5::library_mutex());
    for (Source& x : src) {
      const ArraySpec xs = array_spec(impl_->path, impl_->skeletons, skeleton, "frames", x.name);
      x.d.emplace(open_array(impl_->file, s, skeleton, "frames", x.name, xs));
      x.expected = x.d->string_attribute("checksum_xxh64");
    }
  }
  struct Close {
    std::array<Source, 2>& src;
    ~Close() {
      std::lock_guard lib(h5::library_mutex());
      for (Source& x : src) x.d.reset();
    }
  } close{src};
  std::vector<std::vector<float>> out(fields.size());
  std::vector<const float*> out_rows(fields.size());
  rows_per_block = std::max<std::uint64_t>(rows_per_block, 1);
  std::uint64_t row = 0;
  for (std::size_t i = 0; i < s.clips.size();) {
    // Whole clips, in row order, up to at least rows_per_block rows.
    std::size_t end = i;
    std::uint64_t count = 0;
    while (end < s.clips.size() && (end == i || count < rows_per_block)) {
      const IndexClip& c = impl_->clips[s.clips[end]];
      if (c.frame_start != row + count)
        throw InputError(impl_->path.string(), 0,
                         "/skeletons/" + std::to_string(skeleton) +
                             ": clips do not cover the frame rows in order");
      count += c.frame_count;
      ++end;
    }
    {
      std::lock_guard lib(h5::library_mutex());
      for (Source& x : src) {
        x.rows.resize(count * x.per_row);
        x.d->read_rows_into<float>(row, count, x.rows.data());
      }
    }
    for (Source& x : src) x.hash.update(x.rows.data(), x.rows.size() * sizeof(float));
    for (std::size_t f = 0; f < fields.size(); ++f) {
      out[f].resize(count * per_row[f]);
      out_rows[f] = out[f].data();
    }
    // Isolated: a caller may hold a lock (a search cache's mutex) that a
    // task stolen while waiting here would wait on.
    tbb::this_task_arena::isolate([&] {
      tbb::parallel_for(i, end, [&](std::size_t k) {
        const IndexClip& c = impl_->clips[s.clips[k]];
        if (c.frame_count == 0) return;
        const std::uint64_t at = c.frame_start - row;
        const ClipDynamics dyn = clip_dynamics_from_rows(
            model, {std::span<const float>(src[0].rows)
                        .subspan(at * src[0].per_row, c.frame_count * src[0].per_row),
                    std::span<const float>(src[1].rows)
                        .subspan(at * src[1].per_row, c.frame_count * src[1].per_row),
                    c.frame_count, c.frame_time_s});
        for (std::size_t f = 0; f < fields.size(); ++f)
          derived_frame_rows(model, dyn, fields[f], transition_time_s,
                             out[f].data() + at * per_row[f]);
      });
    });
    fn(row, count, out_rows);
    row += count;
    i = end;
  }
  for (const Source& x : src)
    if (hex64(x.hash.digest()) != x.expected)
      throw InputError(impl_->path.string(), 0,
                       "/skeletons/" + std::to_string(skeleton) + "/frames/" + x.name +
                           ": checksum mismatch (the index is damaged)");
}

std::span<const float> Index::clip_frames(std::size_t clip, std::string_view field) const {
  const IndexClip& c = impl_->clips.at(clip);
  const IndexArray& a = array(c.skeleton, "frames", field);
  return a.rows_f32(c.frame_start, c.frame_count);
}

std::span<const double> Index::clip_energy_prefix(std::size_t clip) const {
  const IndexClip& c = impl_->clips.at(clip);
  const IndexArray& a = array(c.skeleton, "frames", "energy_prefix_J");
  return std::span<const double>(a.f64).subspan(c.frame_start, c.frame_count);
}

DynamicsModel Index::dynamics_model(std::uint32_t skeleton) const {
  const IndexSkeleton& s = impl_->skeletons.at(skeleton);
  DynamicsModel m = build_dynamics_model(s.skeleton, s.body, impl_->info.energy_params);
  if (m.segments != s.segments)
    throw InputError(impl_->path.string(), 0,
                     "/skeletons/" + std::to_string(skeleton) +
                         "/segments: disagree with the stored body masses");
  return m;
}

}  // namespace mocap
