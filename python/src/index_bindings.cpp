// _mocap.Index: an index file's metadata as dicts and its arrays as numpy
// views (no copies; the arrays keep the index open). The Python package
// (python/mocap/__init__.py) wraps it in Index, Clip and Skeleton classes.
#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>

#include <string>
#include <vector>

#include "bindings.hpp"
#include "mocap/common/io/index.hpp"
#include "mocap/common/util/error.hpp"

namespace mocap::python {

namespace {

using IndexPtr = std::shared_ptr<OpenIndex>;

py::dict info_dict(const IndexInfo& i) {
  py::dict d;
  d["format"] = i.format;
  d["schema_version"] = i.schema_version;
  d["build_tool"] = i.build_tool;
  d["build_time_utc"] = i.build_time_utc;
  d["character_json"] = i.character_json;
  d["character_name"] = i.character_name;
  d["character_total_mass_kg"] = i.character_total_mass_kg;
  d["transition_time_s"] = i.transition_time_s;
  d["unit_option"] = i.unit_option;
  d["deflate_level"] = i.deflate_level;
  py::dict e;
  e["gravity_mps2"] = i.energy_params.gravity_mps2;
  e["ground_height_m"] = i.energy_params.ground_height_m;
  e["contact_height_m"] = i.energy_params.contact_height_m;
  e["contact_speed_mps"] = i.energy_params.contact_speed_mps;
  e["friction_coefficient"] = i.energy_params.friction_coefficient;
  e["contact_patch_radius_m"] = i.energy_params.contact_patch_radius_m;
  d["energy_params"] = e;
  d["block_sizes"] = i.block_sizes;
  d["clip_count"] = i.clip_count;
  d["frame_count"] = i.frame_count;
  d["skeleton_count"] = i.skeleton_count;
  d["skipped_count"] = i.skipped_count;
  return d;
}

py::dict clip_dict(const Index& index, std::size_t c) {
  const IndexClip& clip = index.clips().at(c);
  py::dict d;
  d["number"] = c;
  d["path"] = clip.path;
  d["size_bytes"] = clip.size_bytes;
  d["mtime_ns"] = clip.mtime_ns;
  d["content_hash"] = clip.content_hash;
  d["skeleton"] = clip.skeleton;
  d["row"] = clip.row;
  d["frame_start"] = clip.frame_start;
  d["frame_count"] = clip.frame_count;
  d["frame_time_s"] = clip.frame_time_s;
  d["unit"] = clip.unit;
  d["unit_scale_m"] = clip.unit_scale_m;
  d["status"] = clip_status_name(clip.status);
  d["label_source"] = label_source_name(clip.label_source);
  // Only the keys with a label, as search results list them.
  py::dict labels;
  for (std::size_t k = 0; k < index.label_keys().size() && k < clip.labels.size(); ++k)
    if (!clip.labels[k].empty()) labels[py::str(index.label_keys()[k])] = clip.labels[k];
  d["labels"] = labels;
  return d;
}

// A skeleton's table. Arrays are copies (small: one row per joint).
py::dict skeleton_dict(const Index& index, std::uint32_t k) {
  const IndexSkeleton& s = index.skeletons().at(k);
  const Skeleton& sk = s.skeleton;
  const std::size_t n = sk.joint_count();
  py::dict d;
  d["number"] = k;
  d["id"] = s.id;
  d["joint_names"] = sk.names;
  std::vector<std::int32_t> parents(sk.parents.begin(), sk.parents.end());
  d["parents"] = owned_array<std::int32_t>({n}, parents);
  std::vector<double> offsets, end_sites, masses, scales;
  for (std::size_t j = 0; j < n; ++j) {
    for (int a = 0; a < 3; ++a) {
      offsets.push_back(sk.offsets_m[j][a]);
      end_sites.push_back(sk.end_sites_m[j][a]);
    }
    masses.push_back(j < s.body.segments.size() ? s.body.segments[j].mass_kg : 0.0);
    scales.push_back(sk.translation_scales.empty() ? 1.0 : sk.translation_scales[j]);
  }
  d["offsets_m"] = owned_array<double>({n, 3}, offsets);
  d["end_sites_m"] = owned_array<double>({n, 3}, end_sites);
  std::vector<bool> has_end(sk.has_end_site.begin(), sk.has_end_site.end());
  py::array_t<bool> has_end_site(static_cast<py::ssize_t>(n));
  for (std::size_t j = 0; j < n; ++j) has_end_site.mutable_at(j) = has_end[j];
  d["has_end_site"] = has_end_site;
  d["translation_scales"] = owned_array<double>({n}, scales);
  d["channels"] = s.channels;
  d["unit_scale_m"] = sk.unit_scale_m;
  d["root_joint"] = s.root_joint;
  std::vector<std::int32_t> segments(s.segments.begin(), s.segments.end());
  d["segments"] = owned_array<std::int32_t>({segments.size()}, segments);
  d["masses_kg"] = owned_array<double>({n}, masses);
  d["total_mass_kg"] = s.body.total_mass_kg;
  d["frame_count"] = s.frame_count;
  d["clips"] = s.clips;
  return d;
}

// The table a group's fields are described by.
std::span<const IndexFieldSpec> group_fields(std::string_view group) {
  if (group == "frames") return kFrameFields;
  if (group == "blocks16" || group == "blocks64") return kBlockFields;
  if (group == "clip_bounds") return kClipBoundFields;
  throw InputError(
      "group", 0,
      "expected frames, blocks16, blocks64 or clip_bounds, got '" + std::string(group) + "'");
}

const IndexFieldSpec& field_spec(std::string_view group, std::string_view field) {
  const auto table = group_fields(group);
  const int f = find_field(table, field);
  if (f < 0) {
    std::string names;
    for (const IndexFieldSpec& s : table)
      names += (names.empty() ? "" : ", ") + std::string(s.name);
    throw InputError(std::string(group), 0,
                     "no field '" + std::string(field) + "' (fields: " + names + ")");
  }
  return table[static_cast<std::size_t>(f)];
}

// Shape of `rows` rows of a field of skeleton k.
std::vector<std::size_t> field_shape(const Index& index, std::uint32_t k,
                                     const IndexFieldSpec& spec, std::size_t rows) {
  const IndexSkeleton& s = index.skeletons().at(k);
  std::vector<std::size_t> shape{rows};
  for (std::size_t d : row_dims(spec.shape, s.skeleton.joint_count(), s.segments.size()))
    shape.push_back(d);
  return shape;
}

std::uint32_t checked_skeleton(const Index& index, std::size_t k) {
  if (k >= index.skeletons().size())
    throw py::index_error("no skeleton " + std::to_string(k) + " (the index has " +
                          std::to_string(index.skeletons().size()) + ")");
  return static_cast<std::uint32_t>(k);
}

std::size_t checked_clip(const Index& index, std::size_t c) {
  if (c >= index.clips().size())
    throw py::index_error("no clip " + std::to_string(c) + " (the index has " +
                          std::to_string(index.clips().size()) + ")");
  return c;
}

// Skeleton k's whole array (every row of the group), as a view.
py::array group_array(const IndexPtr& self, std::size_t skeleton, const std::string& group,
                      const std::string& field) {
  const Index& index = self->index();
  const std::uint32_t k = checked_skeleton(index, skeleton);
  const IndexFieldSpec& spec = field_spec(group, field);
  const IndexArray* a = nullptr;
  {
    py::gil_scoped_release release;  // the first use reads the dataset
    a = &index.array(k, group, field);
  }
  const auto shape = field_shape(index, k, spec, a->rows);
  const py::object owner = py::cast(self);
  if (spec.dtype == IndexDType::f64) return readonly_view(a->f64.data(), shape, owner);
  return readonly_view(a->f32.data(), shape, owner);
}

// A clip's rows of a frame field, as a view.
py::array clip_array(const IndexPtr& self, std::size_t clip, const std::string& field) {
  const Index& index = self->index();
  const std::size_t c = checked_clip(index, clip);
  const IndexFieldSpec& spec = field_spec("frames", field);
  const IndexClip& rec = index.clips()[c];
  const auto shape = field_shape(index, rec.skeleton, spec, rec.frame_count);
  const py::object owner = py::cast(self);
  if (spec.dtype == IndexDType::f64) {
    std::span<const double> p;
    {
      py::gil_scoped_release release;
      p = index.clip_energy_prefix(c);
    }
    return readonly_view(p.data(), shape, owner);
  }
  std::span<const float> v;
  {
    py::gil_scoped_release release;
    v = index.clip_frames(c, field);
  }
  return readonly_view(v.data(), shape, owner);
}

}  // namespace

void bind_index(py::module_& m) {
  py::class_<OpenIndex, IndexPtr>(m, "Index",
                                  "An index file (mocap-index build), opened read-only. Low-level: "
                                  "use mocap.Index (python/mocap/__init__.py).")
      .def(py::init([](const std::filesystem::path& path, bool verify) {
             IndexOpenOptions o;
             o.verify_file_checksum = verify;
             py::gil_scoped_release release;
             return std::make_shared<OpenIndex>(Index::open(path, o));
           }),
           py::arg("path"), py::arg("verify") = false,
           "Opens an index; verify=True hashes the whole file against its checksum first.")
      .def_property_readonly("path",
                             [](const IndexPtr& self) { return self->index().path().string(); })
      .def("info", [](const IndexPtr& self) { return info_dict(self->index().info()); })
      .def_property_readonly("label_keys",
                             [](const IndexPtr& self) { return self->index().label_keys(); })
      .def_property_readonly("clip_count",
                             [](const IndexPtr& self) { return self->index().clips().size(); })
      .def_property_readonly("skeleton_count",
                             [](const IndexPtr& self) { return self->index().skeletons().size(); })
      .def_property_readonly("frame_count",
                             [](const IndexPtr& self) { return self->index().frame_count(); })
      .def(
          "clip",
          [](const IndexPtr& self, std::size_t c) {
            return clip_dict(self->index(), checked_clip(self->index(), c));
          },
          py::arg("number"))
      .def("clips",
           [](const IndexPtr& self) {
             py::list out;
             for (std::size_t c = 0; c < self->index().clips().size(); ++c)
               out.append(clip_dict(self->index(), c));
             return out;
           })
      .def(
          "skeleton",
          [](const IndexPtr& self, std::size_t k) {
            return skeleton_dict(self->index(), checked_skeleton(self->index(), k));
          },
          py::arg("number"))
      .def("skipped",
           [](const IndexPtr& self) {
             py::list out;
             for (const IndexSkippedFile& f : self->index().skipped()) {
               py::dict d;
               d["path"] = f.path;
               d["reason"] = f.reason;
               d["size_bytes"] = f.size_bytes;
               d["mtime_ns"] = f.mtime_ns;
               out.append(d);
             }
             return out;
           })
      .def("array", &group_array, py::arg("skeleton"), py::arg("group"), py::arg("field"),
           "Every row of one array of a skeleton (group frames, blocks16, blocks64 or "
           "clip_bounds): a read-only view, float32 (float64 for energy_prefix_J).")
      .def("clip_frames", &clip_array, py::arg("clip"), py::arg("field"),
           "A clip's rows of a per-frame field: a read-only view of shape (F, ...).")
      .def_static(
          "fields",
          [](const std::string& group) {
            py::list out;
            for (const IndexFieldSpec& s : group_fields(group)) {
              py::dict d;
              d["name"] = s.name;
              d["dtype"] = s.dtype == IndexDType::f64 ? "float64" : "float32";
              d["unit"] = s.unit;
              d["description"] = s.description;
              // In the file (h5py reads it) or derived on load by the reader.
              d["stored"] = group != "frames" || frame_field_stored(s.name, kIndexSchemaVersion);
              out.append(d);
            }
            return out;
          },
          py::arg("group") = "frames", "The fields of a group, with units and descriptions.");
}

}  // namespace mocap::python
