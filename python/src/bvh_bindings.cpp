// _mocap.Bvh: BVH files to and from numpy arrays, with the libraries' reader
// and writer (mocap/common/io/bvh.hpp) and forward kinematics
// (mocap/common/dynamics/kinematics.hpp). A Bvh is a RawClip: the file as it is (file
// units, each joint's channels in file order, Euler degrees).
#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>

#include <cmath>
#include <optional>
#include <string>
#include <vector>

#include "bindings.hpp"
#include "mocap/common/dynamics/kinematics.hpp"
#include "mocap/common/io/bvh.hpp"
#include "mocap/common/io/raw_clip.hpp"
#include "mocap/common/io/units.hpp"
#include "mocap/common/util/error.hpp"
#include "mocap/search/query.hpp"

namespace mocap::python {

namespace {

using ClipPtr = std::shared_ptr<RawClip>;
using DoubleArray = py::array_t<double, py::array::c_style | py::array::forcecast>;

Channel parse_channel(const std::string& name) {
  for (int c = 0; c < 6; ++c)
    if (name == channel_name(static_cast<Channel>(c))) return static_cast<Channel>(c);
  throw py::value_error("channels: '" + name +
                        "' is not a BVH channel (Xposition, Yposition, Zposition, Xrotation, "
                        "Yrotation, Zrotation)");
}

// Checks an array's shape; `what` names it in the message.
void check_shape(const DoubleArray& a, const std::vector<py::ssize_t>& shape, const char* what) {
  bool ok = a.ndim() == static_cast<py::ssize_t>(shape.size());
  for (std::size_t d = 0; ok && d < shape.size(); ++d) ok = a.shape(d) == shape[d];
  if (!ok) {
    std::string want, got;
    for (py::ssize_t d : shape) want += (want.empty() ? "" : ", ") + std::to_string(d);
    for (py::ssize_t d = 0; d < a.ndim(); ++d)
      got += (got.empty() ? "" : ", ") + std::to_string(a.shape(d));
    throw py::value_error(std::string(what) + ": expected shape (" + want + "), got (" + got + ")");
  }
}

// The joints of a clip from names, parents, offsets and optional End Sites
// (checked: parents before children, shapes). Channels are left empty.
RawClip joints_from_arrays(const std::vector<std::string>& names, const std::vector<int>& parents,
                           const DoubleArray& offsets, const std::optional<DoubleArray>& end_sites,
                           double frame_time_s, const std::string& source) {
  const std::size_t n = names.size();
  if (n == 0) throw py::value_error("joint_names: at least one joint");
  if (parents.size() != n)
    throw py::value_error("parents: expected " + std::to_string(n) + " values, got " +
                          std::to_string(parents.size()));
  check_shape(offsets, {static_cast<py::ssize_t>(n), 3}, "offsets");
  if (end_sites) check_shape(*end_sites, {static_cast<py::ssize_t>(n), 3}, "end_sites");
  if (!(frame_time_s > 0.0 && std::isfinite(frame_time_s)))
    throw py::value_error("frame_time_s: must be a number of seconds > 0");
  RawClip clip;
  clip.source = source;
  clip.frame_time_s = frame_time_s;
  for (std::size_t j = 0; j < n; ++j) {
    const int p = parents[j];
    if (p < -1 || p >= static_cast<int>(j))
      throw py::value_error("parents[" + std::to_string(j) + "]: expected -1 (a root) or a joint " +
                            "before it, got " + std::to_string(p));
  }
  const auto o = offsets.unchecked<2>();
  for (std::size_t j = 0; j < n; ++j) {
    RawJoint rj;
    rj.name = names[j];
    rj.parent = parents[j];
    const auto jj = static_cast<py::ssize_t>(j);
    rj.offset = Eigen::Vector3d(o(jj, 0), o(jj, 1), o(jj, 2));
    // An End Site where its row is given (not NaN).
    if (end_sites) {
      const auto e = end_sites->unchecked<2>();
      const Eigen::Vector3d site(e(jj, 0), e(jj, 1), e(jj, 2));
      rj.has_end_site = !site.hasNaN();
      if (rj.has_end_site) rj.end_site = site;
    }
    clip.joints.push_back(std::move(rj));
  }
  return clip;
}

// Numbers the joints' channel columns and fills the values (F x C).
void set_values(RawClip& clip, const DoubleArray& values) {
  clip.channel_count = 0;
  for (RawJoint& j : clip.joints) {
    j.first_column = clip.channel_count;
    clip.channel_count += j.channels.size();
  }
  if (values.ndim() != 2 || values.shape(1) != static_cast<py::ssize_t>(clip.channel_count))
    throw py::value_error("values: expected shape (frames, " + std::to_string(clip.channel_count) +
                          ") for these channels");
  clip.frame_count = static_cast<std::size_t>(values.shape(0));
  clip.values.assign(values.data(), values.data() + values.size());
}

ClipPtr from_channels(const std::vector<std::string>& names, const std::vector<int>& parents,
                      const DoubleArray& offsets,
                      const std::vector<std::vector<std::string>>& channels,
                      const DoubleArray& values, double frame_time_s,
                      const std::optional<DoubleArray>& end_sites, const std::string& source) {
  auto clip = std::make_shared<RawClip>(
      joints_from_arrays(names, parents, offsets, end_sites, frame_time_s, source));
  if (channels.size() != names.size())
    throw py::value_error("channels: expected one list per joint (" + std::to_string(names.size()) +
                          "), got " + std::to_string(channels.size()));
  for (std::size_t j = 0; j < channels.size(); ++j) {
    if (channels[j].size() > 6)
      throw py::value_error("channels[" + std::to_string(j) + "]: at most 6 channels");
    for (const std::string& c : channels[j]) clip->joints[j].channels.push_back(parse_channel(c));
  }
  set_values(*clip, values);
  return clip;
}

ClipPtr from_rotations(const std::vector<std::string>& names, const std::vector<int>& parents,
                       const DoubleArray& offsets, const DoubleArray& rotations,
                       const DoubleArray& root_positions, double frame_time_s,
                       const std::string& order, const std::optional<DoubleArray>& end_sites,
                       const std::string& source) {
  auto clip = std::make_shared<RawClip>(
      joints_from_arrays(names, parents, offsets, end_sites, frame_time_s, source));
  const auto axes = parse_euler_order(order);
  if (!axes)
    throw py::value_error("order: expected 3 distinct letters of X, Y, Z, got '" + order + "'");
  const std::size_t n = names.size();
  if (rotations.ndim() != 3)
    throw py::value_error("rotations: expected shape (frames, " + std::to_string(n) + ", 4)");
  const auto frames = rotations.shape(0);
  check_shape(rotations, {frames, static_cast<py::ssize_t>(n), 4}, "rotations");
  std::vector<std::size_t> roots;
  for (std::size_t j = 0; j < n; ++j)
    if (parents[j] < 0) roots.push_back(j);
  const auto r_count = static_cast<py::ssize_t>(roots.size());
  if (root_positions.ndim() == 2 && r_count == 1)
    check_shape(root_positions, {frames, 3}, "root_positions");
  else
    check_shape(root_positions, {frames, r_count, 3}, "root_positions");
  static const Channel rotation_channels[3] = {Channel::Xrotation, Channel::Yrotation,
                                               Channel::Zrotation};
  for (std::size_t j = 0; j < n; ++j) {
    auto& ch = clip->joints[j].channels;
    if (parents[j] < 0) ch = {Channel::Xposition, Channel::Yposition, Channel::Zposition};
    for (std::uint8_t a : *axes) ch.push_back(rotation_channels[a]);
  }
  clip->channel_count = 0;
  for (RawJoint& j : clip->joints) {
    j.first_column = clip->channel_count;
    clip->channel_count += j.channels.size();
  }
  clip->frame_count = static_cast<std::size_t>(frames);
  clip->values.resize(clip->frame_count * clip->channel_count);
  const auto q = rotations.unchecked<3>();
  const double* pos = root_positions.data();
  for (py::ssize_t f = 0; f < frames; ++f) {
    double* row = clip->values.data() + static_cast<std::size_t>(f) * clip->channel_count;
    std::size_t root = 0;
    for (std::size_t j = 0; j < n; ++j) {
      const auto jj = static_cast<py::ssize_t>(j);
      Eigen::Quaterniond r(q(f, jj, 0), q(f, jj, 1), q(f, jj, 2), q(f, jj, 3));
      const double norm = r.norm();
      if (!(norm > 1e-12 && std::isfinite(norm)))
        throw py::value_error("rotations[" + std::to_string(f) + ", " + std::to_string(j) +
                              "]: not a rotation (zero or non-finite quaternion)");
      r.coeffs() /= norm;
      double* out = row + clip->joints[j].first_column;
      if (parents[j] < 0) {
        const double* p = pos + (static_cast<std::size_t>(f) * roots.size() + root++) * 3;
        for (int a = 0; a < 3; ++a) *out++ = p[a];
      }
      const Eigen::Vector3d e = quaternion_to_euler(r, *axes);
      for (int a = 0; a < 3; ++a) *out++ = e[a];
    }
  }
  return clip;
}

// Metres per file unit: a unit name, or "auto" (detect_unit).
double unit_scale(const RawClip& clip, const std::string& unit, std::string& name) {
  if (unit == "auto") {
    const LengthUnit u = detect_unit(clip);
    name = unit_name(u);
    return unit_scale_m(u);
  }
  const auto u = parse_unit(unit);
  if (!u)
    throw InputError("unit", 0, "expected m, dm, cm, mm, inch, cmu or auto, got '" + unit + "'");
  name = unit_name(*u);
  return unit_scale_m(*u);
}

py::dict motion_dict(const RawClip& clip, const std::string& unit) {
  std::string name;
  const double scale = unit_scale(clip, unit, name);
  ClipMotion m;
  {
    py::gil_scoped_release release;
    m = clip_motion_from_raw(clip, scale);
  }
  const auto f = static_cast<py::ssize_t>(m.frame_count);
  const auto n = static_cast<py::ssize_t>(m.joint_count());
  py::array_t<double> positions({f, n, py::ssize_t{3}}), translations({f, n, py::ssize_t{3}});
  py::array_t<double> world({f, n, py::ssize_t{4}}), local({f, n, py::ssize_t{4}});
  double* p = positions.mutable_data();
  double* t = translations.mutable_data();
  double* w = world.mutable_data();
  double* l = local.mutable_data();
  const auto put_q = [](double*& out, const Eigen::Quaterniond& q) {
    *out++ = q.w();
    *out++ = q.x();
    *out++ = q.y();
    *out++ = q.z();
  };
  for (std::size_t i = 0; i < m.world_positions_m.size(); ++i) {
    for (int a = 0; a < 3; ++a) {
      *p++ = m.world_positions_m[i][a];
      *t++ = m.local_translations_m[i][a];
    }
    put_q(w, m.world_rotations[i]);
    put_q(l, m.local_rotations[i]);
  }
  py::dict d;
  d["unit"] = name;
  d["unit_scale_m"] = scale;
  d["joint_positions_m"] = positions;
  d["world_rotations"] = world;
  d["local_rotations"] = local;
  d["local_translations_m"] = translations;
  return d;
}

std::vector<std::size_t> joint_shape(const RawClip& c, std::size_t k) {
  return k ? std::vector<std::size_t>{c.joints.size(), k}
           : std::vector<std::size_t>{c.joints.size()};
}

}  // namespace

void bind_bvh(py::module_& m) {
  py::class_<RawClip, ClipPtr>(m, "Bvh",
                               "A BVH clip as read (file units, channels in file order, Euler "
                               "degrees); low-level, see mocap.Bvh.")
      .def_readonly("source", &RawClip::source)
      .def_readonly("frame_time_s", &RawClip::frame_time_s)
      .def_readonly("frame_count", &RawClip::frame_count)
      .def_readonly("channel_count", &RawClip::channel_count)
      .def_property_readonly("joint_names",
                             [](const RawClip& c) {
                               std::vector<std::string> out;
                               for (const RawJoint& j : c.joints) out.push_back(j.name);
                               return out;
                             })
      .def_property_readonly("parents",
                             [](const RawClip& c) {
                               std::vector<std::int32_t> p;
                               for (const RawJoint& j : c.joints) p.push_back(j.parent);
                               return owned_array<std::int32_t>(joint_shape(c, 0), p);
                             })
      .def_property_readonly("offsets",
                             [](const RawClip& c) {
                               std::vector<double> v;
                               for (const RawJoint& j : c.joints)
                                 for (int a = 0; a < 3; ++a) v.push_back(j.offset[a]);
                               return owned_array<double>(joint_shape(c, 3), v);
                             })
      .def_property_readonly("end_sites",
                             [](const RawClip& c) {
                               std::vector<double> v;
                               for (const RawJoint& j : c.joints)
                                 for (int a = 0; a < 3; ++a)
                                   v.push_back(j.has_end_site ? j.end_site[a] : std::nan(""));
                               return owned_array<double>(joint_shape(c, 3), v);
                             })
      .def_property_readonly("channels",
                             [](const RawClip& c) {
                               std::vector<std::vector<std::string>> out;
                               for (const RawJoint& j : c.joints) {
                                 out.emplace_back();
                                 for (Channel ch : j.channels)
                                   out.back().push_back(channel_name(ch));
                               }
                               return out;
                             })
      .def_property_readonly("first_columns",
                             [](const RawClip& c) {
                               std::vector<std::int64_t> v;
                               for (const RawJoint& j : c.joints)
                                 v.push_back(static_cast<std::int64_t>(j.first_column));
                               return owned_array<std::int64_t>(joint_shape(c, 0), v);
                             })
      .def_property_readonly(
          "values",
          [](const ClipPtr& c) {
            return readonly_view(c->values.data(), {c->frame_count, c->channel_count}, py::cast(c));
          },
          "(F, C) channel values as in the file (file units, degrees): a read-only view.")
      .def(
          "detect_unit", [](const RawClip& c) { return std::string(unit_name(detect_unit(c))); },
          "The length unit detected from the skeleton's height (docs/units.md).")
      .def("motion", &motion_dict, py::arg("unit") = "auto",
           "Forward kinematics in metres: a dict of (F, J, 3) joint_positions_m and "
           "local_translations_m, (F, J, 4) world_rotations and local_rotations (w, x, y, z), "
           "and the unit used.")
      .def("text", &write_bvh, py::arg("precision") = 9, "BVH text (the libraries' writer).")
      .def(
          "write",
          [](const RawClip& c, const std::filesystem::path& path, int precision) {
            py::gil_scoped_release release;
            write_bvh_file(c, path, precision);
          },
          py::arg("path"), py::arg("precision") = 9,
          "Writes BVH (a temporary file renamed into place).")
      .def(
          "export_layout",
          [](const RawClip& c, double tolerance) {
            return std::make_shared<RawClip>(to_export_layout(c, tolerance));
          },
          py::arg("tolerance") = 1e-4,
          "The clip in the layout Blender and three.js load alike: position channels on the "
          "root only (mocap/common/io/bvh.hpp to_export_layout).")
      .def_static("from_channels", &from_channels, py::arg("joint_names"), py::arg("parents"),
                  py::arg("offsets"), py::arg("channels"), py::arg("values"),
                  py::arg("frame_time_s"), py::arg("end_sites") = std::nullopt,
                  py::arg("source") = "<arrays>")
      .def_static("from_rotations", &from_rotations, py::arg("joint_names"), py::arg("parents"),
                  py::arg("offsets"), py::arg("rotations"), py::arg("root_positions"),
                  py::arg("frame_time_s"), py::arg("order") = "ZXY",
                  py::arg("end_sites") = std::nullopt, py::arg("source") = "<arrays>");

  m.def(
      "read_bvh",
      [](const std::filesystem::path& path) {
        py::gil_scoped_release release;
        return std::make_shared<RawClip>(read_bvh_file(path));
      },
      py::arg("path"), "Reads a BVH file.");
  m.def(
      "parse_bvh",
      [](const std::string& text, const std::string& source) {
        py::gil_scoped_release release;
        return std::make_shared<RawClip>(parse_bvh(text, source));
      },
      py::arg("text"), py::arg("source") = "<text>", "Parses BVH text.");
}

}  // namespace mocap::python
