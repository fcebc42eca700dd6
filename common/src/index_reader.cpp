// Runtime reader of the HDF5 index (mocap/index.hpp, docs/index-format.md).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <map>
#include <optional>
#include <mutex>
#include <sstream>
#include <tuple>
#include <type_traits>

#include "mocap/error.hpp"
#include "mocap/file.hpp"
#include "mocap/hdf5.hpp"
#include "mocap/index.hpp"
#include "mocap/xxh64.hpp"

namespace mocap {

namespace fs = std::filesystem;

std::size_t row_elements(RowShape s, std::size_t joints, std::size_t segments) {
  std::size_t n = 1;
  for (auto d : row_dims(s, joints, segments)) n *= d;
  return n;
}

std::vector<std::size_t> row_dims(RowShape s, std::size_t joints, std::size_t segments) {
  switch (s) {
    case RowShape::scalar: return {};
    case RowShape::vec3: return {3};
    case RowShape::joints3: return {joints, 3};
    case RowShape::joints4: return {joints, 4};
    case RowShape::segments3: return {segments, 3};
    case RowShape::segments9: return {segments, 9};
  }
  return {};
}

int find_field(std::span<const IndexFieldSpec> table, std::string_view name) {
  for (std::size_t i = 0; i < table.size(); ++i)
    if (name == table[i].name) return static_cast<int>(i);
  return -1;
}

const char* clip_status_name(ClipStatus s) {
  switch (s) {
    case ClipStatus::parsed_new: return "new";
    case ClipStatus::parsed_changed: return "changed";
    case ClipStatus::reused: return "reused";
  }
  return "new";
}

const char* label_source_name(LabelSource s) {
  switch (s) {
    case LabelSource::none: return "none";
    case LabelSource::file_name: return "file_name";
    case LabelSource::sidecar: return "sidecar";
    case LabelSource::sidecar_cfg: return "sidecar_cfg";
  }
  return "none";
}

// ---------------------------------------------------------------------------
// User block: "MOCAP-INDEX-USERBLOCK 1\nbytes <N>\nxxh64 <hex>\n", zero padded.

namespace {
constexpr const char* kUserBlockMagic = "MOCAP-INDEX-USERBLOCK 1\n";

struct FileCloser {
  void operator()(std::FILE* f) const {
    if (f) std::fclose(f);
  }
};
using FilePtr = std::unique_ptr<std::FILE, FileCloser>;
}  // namespace

void seal_index_file(const fs::path& path) {
  FilePtr f(std::fopen(path.c_str(), "r+b"));
  if (!f) throw InputError(path.string(), 0, "cannot open to seal");
  std::error_code ec;
  const std::uint64_t size = fs::file_size(path, ec);
  if (ec || size < kIndexUserBlockBytes) throw InputError(path.string(), 0, "too small to be an index");
  const std::uint64_t h = hash_file(path, kIndexUserBlockBytes);
  std::string block = std::string(kUserBlockMagic) + "bytes " + std::to_string(size) + "\nxxh64 " + hex64(h) + "\n";
  block.resize(kIndexUserBlockBytes, '\0');
  if (std::fseek(f.get(), 0, SEEK_SET) != 0 || std::fwrite(block.data(), 1, block.size(), f.get()) != block.size() ||
      std::fflush(f.get()) != 0)
    throw InputError(path.string(), 0, "cannot write the user block");
}

void check_index_file(const fs::path& path, bool hash) {
  const std::string p = path.string();
  std::error_code ec;
  if (!fs::is_regular_file(path, ec)) throw InputError(p, 0, "no such index file");
  const std::uint64_t size = fs::file_size(path, ec);
  if (ec) throw InputError(p, 0, "cannot get the file size");
  FilePtr f(std::fopen(path.c_str(), "rb"));
  if (!f) throw InputError(p, 0, "cannot open for reading");
  char block[kIndexUserBlockBytes] = {0};
  const std::size_t got = std::fread(block, 1, sizeof block, f.get());
  const std::size_t magic_len = std::strlen(kUserBlockMagic);
  if (got < magic_len || std::memcmp(block, kUserBlockMagic, magic_len) != 0)
    throw InputError(p, 0, "not a mocap index (no index user block; was it written by mocap-index build?)");
  std::istringstream in(std::string(block + magic_len, strnlen(block + magic_len, sizeof block - magic_len)));
  std::string k1, k2, hex;
  std::uint64_t expected = 0;
  if (!(in >> k1 >> expected >> k2 >> hex) || k1 != "bytes" || k2 != "xxh64" || hex.size() != 16)
    throw InputError(p, 0, "damaged index user block");
  // The block must be exactly what seal_index_file writes (padding included).
  std::string canonical = std::string(kUserBlockMagic) + "bytes " + std::to_string(expected) + "\nxxh64 " + hex + "\n";
  canonical.resize(kIndexUserBlockBytes, '\0');
  if (got != kIndexUserBlockBytes || std::memcmp(canonical.data(), block, kIndexUserBlockBytes) != 0)
    throw InputError(p, 0, "damaged index user block");
  if (size < expected)
    throw InputError(p, 0, "truncated: " + std::to_string(size) + " of " + std::to_string(expected) + " bytes");
  if (size > expected)
    throw InputError(p, 0, "damaged: " + std::to_string(size - expected) + " unexpected bytes after the index");
  if (!hash) return;
  const std::uint64_t h = hash_file(path, kIndexUserBlockBytes);
  if (hex64(h) != hex)
    throw InputError(p, 0, "checksum mismatch: the file is damaged (xxh64 " + hex64(h) + ", expected " + hex + ")");
}

// ---------------------------------------------------------------------------
// Reading helpers

namespace {

/// What a streaming pass over a dataset found besides its checksum.
struct ValueFindings {
  std::uint64_t first_non_finite = UINT64_MAX;  // element index
  std::uint64_t first_bad_quaternion = UINT64_MAX;  // quaternion index (when checked)
};

/// XXH64 of a dataset's values in their stored type (strings: bytes + NUL
/// each), read in blocks of rows (bounded memory). Float values are checked
/// to be finite; with `quaternions`, rows of 4 values to be unit with w >= 0.
std::uint64_t dataset_checksum(const h5::Dataset& d, ValueFindings* findings = nullptr, bool quaternions = false) {
  Xxh64 h;
  const H5T_class_t cls = d.type_class();
  if (cls == H5T_STRING) {
    for (const auto& s : d.read_strings()) h.update(s.c_str(), s.size() + 1);
    return h.digest();
  }
  if (cls == H5T_ENUM) {
    const auto v = d.read_enum();
    h.update(v.data(), v.size());
    return h.digest();
  }
  const std::size_t bytes = d.element_bytes();
  const hsize_t rows = d.rows();
  const hsize_t per_row = std::max<hsize_t>(d.row_elements(), 1);
  const hsize_t step = std::max<hsize_t>(1, (hsize_t{1} << 20) / per_row);
  auto run = [&](auto tag) {
    using T = decltype(tag);
    if (d.shape().empty()) {
      const auto v = d.read_rows<T>(0, 1);
      h.update(v.data(), v.size() * sizeof(T));
      return;
    }
    std::vector<T> buf;
    for (hsize_t r = 0; r < rows; r += step) {
      const hsize_t n = std::min(step, rows - r);
      buf.resize(static_cast<std::size_t>(n * per_row));
      d.read_rows_into<T>(r, n, buf.data());
      h.update(buf.data(), buf.size() * sizeof(T));
      if constexpr (std::is_floating_point_v<T>) {
        if (!findings) continue;
        const std::uint64_t base = r * per_row;
        for (std::size_t i = 0; i < buf.size() && findings->first_non_finite == UINT64_MAX; ++i)
          if (!std::isfinite(buf[i])) findings->first_non_finite = base + i;
        if (quaternions)
          for (std::size_t i = 0; i + 3 < buf.size() && findings->first_bad_quaternion == UINT64_MAX; i += 4) {
            double n2 = 0.0;
            for (std::size_t e = 0; e < 4; ++e) n2 += static_cast<double>(buf[i + e]) * static_cast<double>(buf[i + e]);
            if (std::abs(std::sqrt(n2) - 1.0) > 1e-3 || buf[i] < T(0)) findings->first_bad_quaternion = (base + i) / 4;
          }
      }
    }
  };
  if (cls == H5T_FLOAT) {
    if (bytes == 4)
      run(float{});
    else
      run(double{});
  } else if (cls == H5T_INTEGER) {
    h5::Id t(H5Dget_type(d.id()), H5Tclose);
    const bool is_signed = H5Tget_sign(t.get()) == H5T_SGN_2;
    switch (bytes) {
      case 1: is_signed ? run(std::int8_t{}) : run(std::uint8_t{}); break;
      case 4: is_signed ? run(std::int32_t{}) : run(std::uint32_t{}); break;
      case 8: is_signed ? run(std::int64_t{}) : run(std::uint64_t{}); break;
      default: throw InputError(d.file(), 0, d.path() + ": unexpected integer size");
    }
  } else {
    throw InputError(d.file(), 0, d.path() + ": unexpected data type");
  }
  return h.digest();
}

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
    throw InputError(d.file(), 0, d.path() + ": checksum mismatch (xxh64 " + got + ", expected " + expected + ")");
  if (found.first_non_finite != UINT64_MAX)
    problems.push_back(d.path() + ": non-finite value at element " + std::to_string(found.first_non_finite));
  if (found.first_bad_quaternion != UINT64_MAX)
    problems.push_back(d.path() + ": element " + std::to_string(found.first_bad_quaternion) +
                       " is not a unit quaternion with w >= 0");
}

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

std::vector<std::string> read_string_column(const h5::Group& g, const std::string& name, std::size_t rows,
                                            std::size_t per_row = 1) {
  const h5::Dataset d = g.open_dataset(name);
  auto v = d.read_strings();
  if (v.size() != rows * per_row)
    throw InputError(d.file(), 0, d.path() + ": " + std::to_string(v.size()) + " strings, expected " +
                                      std::to_string(rows * per_row));
  return v;
}

std::optional<Channel> parse_channel(const std::string& s) {
  static const char* names[] = {"Xposition", "Yposition", "Zposition", "Xrotation", "Yrotation", "Zrotation"};
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
  mutable std::map<std::tuple<std::uint32_t, std::string, std::string>, std::unique_ptr<IndexArray>> arrays;
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

const fs::path& Index::path() const { return impl_->path; }
const IndexInfo& Index::info() const { return impl_->info; }
const std::vector<IndexClip>& Index::clips() const { return impl_->clips; }
const std::vector<std::string>& Index::label_keys() const { return impl_->label_keys; }
const std::vector<IndexSkeleton>& Index::skeletons() const { return impl_->skeletons; }
const std::vector<IndexSkippedFile>& Index::skipped() const { return impl_->skipped; }
std::uint64_t Index::frame_count() const { return impl_->frames; }

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
      throw InputError(file, 0, g.path() + "/parents: joint " + std::to_string(j) + " comes before its parent");
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
        if (m.rotation_count >= 3) throw InputError(file, 0, g.path() + "/channels: more than 3 rotations");
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
    if (!cls) throw InputError(file, 0, g.path() + "/segment_class: unknown class '" + classes[j] + "'");
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
      for (int c = 0; c < 3; ++c) seg.inertia_local_kgm2(r, c) = inertia[9 * j + 3 * static_cast<std::size_t>(r) + static_cast<std::size_t>(c)];
    seg.length_m = length[j];
    s.body.total_mass_kg += seg.mass_kg;
  }
  const auto S = static_cast<std::size_t>(g.int_attribute("segment_count"));
  if (S > J) throw InputError(file, 0, g.path() + ": segment_count exceeds joint_count");
  s.segments = read_column<std::int32_t>(g, "segments", S);
  for (std::size_t i = 0; i < S; ++i)
    if (s.segments[i] < 0 || static_cast<std::size_t>(s.segments[i]) >= J || (i > 0 && s.segments[i] <= s.segments[i - 1]))
      throw InputError(file, 0, g.path() + "/segments: joint indices must be increasing and in range");
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
    throw InputError(file, 0, "not a mocap index (root attribute format is not '" + std::string(kIndexFormat) + "')");
  const std::int64_t version = root.int_attribute("schema_version");
  if (version != kIndexSchemaVersion)
    throw InputError(file, 0,
                     "unsupported index schema version " + std::to_string(version) + " (this build reads " +
                         std::to_string(kIndexSchemaVersion) + "); rebuild the index with this mocap-index");

  IndexInfo& info = impl->info;
  info.format = kIndexFormat;
  info.schema_version = version;
  info.build_tool = root.string_attribute("build_tool");
  info.build_time_utc = root.string_attribute("build_time_utc");
  info.character_json = root.string_attribute("character");
  info.character_name = root.string_attribute("character_name");
  info.character_total_mass_kg = root.double_attribute("character_total_mass_kg");
  info.transition_time_s = root.double_attribute("transition_time_s");
  info.unit_option = root.string_attribute("unit_option");
  info.deflate_level = static_cast<int>(root.int_attribute("deflate_level"));
  info.clip_count = static_cast<std::uint64_t>(root.int_attribute("clip_count"));
  info.frame_count = static_cast<std::uint64_t>(root.int_attribute("frame_count"));
  EnergyParams& ep = info.energy_params;
  ep.gravity_mps2 = root.double_attribute("gravity_mps2");
  ep.ground_height_m = root.double_attribute("ground_height_m");
  ep.contact_height_m = root.double_attribute("contact_height_m");
  ep.contact_speed_mps = root.double_attribute("contact_speed_mps");
  ep.friction_coefficient = root.double_attribute("friction_coefficient");
  ep.contact_patch_radius_m = root.double_attribute("contact_patch_radius_m");
  for (const char* unit_attr : {"length_unit", "time_unit", "mass_unit", "energy_unit", "up_axis"})
    root.string_attribute(unit_attr);  // presence is part of the schema

  // Skeletons.
  const h5::Group skel_group = root.open_group("skeletons");
  const auto skeleton_count = static_cast<std::size_t>(root.int_attribute("skeleton_count"));
  for (std::size_t k = 0; k < skeleton_count; ++k)
    impl->skeletons.push_back(read_skeleton(skel_group.open_group(std::to_string(k)), file));
  if (skel_group.members().size() != skeleton_count)
    throw InputError(file, 0, "/skeletons: " + std::to_string(skel_group.members().size()) +
                                  " groups, root attribute skeleton_count says " + std::to_string(skeleton_count));

  // Clips.
  const h5::Group cg = root.open_group("clips");
  const std::size_t C = static_cast<std::size_t>(info.clip_count);
  const auto paths = read_string_column(cg, "path", C);
  const auto sizes = read_column<std::uint64_t>(cg, "size_bytes", C);
  const auto mtimes = read_column<std::int64_t>(cg, "mtime_ns", C);
  const auto hashes = read_column<std::uint64_t>(cg, "content_xxh64", C);
  const auto skel = read_column<std::uint32_t>(cg, "skeleton", C);
  const auto rows = read_column<std::uint64_t>(cg, "row", C);
  const auto fstart = read_column<std::uint64_t>(cg, "frame_start", C);
  const auto fcount = read_column<std::uint64_t>(cg, "frame_count", C);
  const auto b16 = read_column<std::uint64_t>(cg, "block16_start", C);
  const auto b64 = read_column<std::uint64_t>(cg, "block64_start", C);
  const auto ftime = read_column<double>(cg, "frame_time_s", C);
  const auto uscale = read_column<double>(cg, "unit_scale_m", C);
  const auto unit = read_string_column(cg, "unit", C);
  const auto status = cg.open_dataset("status").read_enum();
  const auto lsrc = cg.open_dataset("label_source").read_enum();
  const h5::Dataset keys_ds = cg.open_dataset("label_keys");
  impl->label_keys = keys_ds.read_strings();
  const std::size_t K = impl->label_keys.size();
  const auto labels = K ? read_string_column(cg, "labels", C, K) : std::vector<std::string>{};
  if (status.size() != C || lsrc.size() != C) throw InputError(file, 0, "/clips: status columns have the wrong length");

  std::vector<std::uint64_t> next_frame(skeleton_count, 0), next_b16(skeleton_count, 0), next_b64(skeleton_count, 0);
  impl->clips.resize(C);
  for (std::size_t c = 0; c < C; ++c) {
    IndexClip& clip = impl->clips[c];
    clip.path = paths[c];
    clip.size_bytes = sizes[c];
    clip.mtime_ns = mtimes[c];
    clip.content_hash = hashes[c];
    clip.skeleton = skel[c];
    clip.row = rows[c];
    clip.frame_start = fstart[c];
    clip.frame_count = fcount[c];
    clip.block16_start = b16[c];
    clip.block64_start = b64[c];
    clip.frame_time_s = ftime[c];
    clip.unit_scale_m = uscale[c];
    clip.unit = unit[c];
    if (status[c] > 2 || lsrc[c] > 3) throw InputError(file, 0, "/clips: bad status or label_source value");
    clip.status = static_cast<ClipStatus>(status[c]);
    clip.label_source = static_cast<LabelSource>(lsrc[c]);
    clip.labels.assign(labels.begin() + static_cast<std::ptrdiff_t>(c * K),
                       labels.begin() + static_cast<std::ptrdiff_t>((c + 1) * K));
    const std::string where = "/clips row " + std::to_string(c) + " (" + clip.path + ")";
    if (c > 0 && !(paths[c - 1] < paths[c])) throw InputError(file, 0, where + ": clips are not sorted by path");
    if (clip.skeleton >= skeleton_count) throw InputError(file, 0, where + ": skeleton out of range");
    IndexSkeleton& s = impl->skeletons[clip.skeleton];
    // Clips of a skeleton occupy consecutive rows, frames and blocks, in clip order.
    if (clip.row != s.clips.size() || clip.frame_start != next_frame[clip.skeleton] ||
        clip.block16_start != next_b16[clip.skeleton] || clip.block64_start != next_b64[clip.skeleton])
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
    if (s.frame_count != next_frame[k] || s.block16_count != next_b16[k] || s.block64_count != next_b64[k])
      throw InputError(file, 0, "/skeletons/" + std::to_string(k) + ": frame or block counts disagree with /clips");
  }
  if (impl->frames != info.frame_count)
    throw InputError(file, 0, "root attribute frame_count disagrees with /clips/frame_count");

  const h5::Group sk = root.open_group("skipped");
  const auto spaths = sk.open_dataset("path").read_strings();
  const auto sreasons = sk.open_dataset("reason").read_strings();
  if (spaths.size() != sreasons.size()) throw InputError(file, 0, "/skipped: path and reason lengths differ");
  for (std::size_t i = 0; i < spaths.size(); ++i) impl->skipped.push_back({spaths[i], sreasons[i]});
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

  std::lock_guard own(impl_->mutex);
  auto key = std::make_tuple(skeleton, std::string(group), std::string(field));
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

void Index::stream_rows(
    std::uint32_t skeleton, std::string_view group, std::string_view field,
    std::uint64_t rows_per_block,
    const std::function<void(std::uint64_t, std::uint64_t, const float*)>& fn) const {
  const ArraySpec as = array_spec(impl_->path, impl_->skeletons, skeleton, group, field);
  const IndexSkeleton& s = impl_->skeletons[skeleton];
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
                     "/skeletons/" + std::to_string(skeleton) + "/segments: disagree with the stored body masses");
  return m;
}

// ---------------------------------------------------------------------------
// verify

namespace {

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
    for (std::uint64_t f = clip.frame_start + 1; f < clip.frame_start + clip.frame_count && !bad; ++f)
      bad = prefix.f64[f] < prefix.f64[f - 1];
    if (bad) problems.push_back(where + "/frames/energy_prefix_J: clip " + clip.path + " is not a prefix sum from 0");
  }
  for (const char* q : {"local_rotations", "world_rotations"}) {
    const IndexArray& a = index.array(k, "frames", q);
    for (std::size_t i = 0; i + 3 < a.f32.size(); i += 4) {
      double n2 = 0.0;
      for (std::size_t e = 0; e < 4; ++e) n2 += static_cast<double>(a.f32[i + e]) * static_cast<double>(a.f32[i + e]);
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
        if (v < kmin.f32[clip.row * kd.row_elements + e] || v > kmax.f32[clip.row * kd.row_elements + e]) bad = true;
      }
    }
    if (bad) problems.push_back(where + "/clip_bounds: clip " + clip.path + " has frames outside its bounds");
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
          if (v < bmin.f32[b * kd.row_elements + e] || v > bmax.f32[b * kd.row_elements + e]) bbad = true;
        }
      }
      if (bbad) problems.push_back(where + "/" + grp + ": clip " + clip.path + " has frames outside its block bounds");
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
            if (!sub.exists(spec.name)) r.problems.push_back(sub.path() + "/" + spec.name + ": dataset is missing");
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
