// Style features and discriminants (mocap/common/motion/style.hpp;
// docs/style.md).
#include "mocap/common/motion/style.hpp"

#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>
#include <functional>
#include <numeric>
#include <set>
#include <string>

#include "mocap/common/body/body.hpp"
#include "mocap/common/body/character.hpp"
#include "mocap/common/body/skeleton.hpp"
#include "mocap/common/dynamics/dynamics.hpp"
#include "mocap/common/dynamics/kinematics.hpp"
#include "mocap/common/io/bvh.hpp"
#include "mocap/common/util/error.hpp"

namespace mocap {
namespace {

void check_range(const std::string& source, std::size_t frames, std::size_t first,
                 std::size_t last) {
  if (first > last || last >= frames)
    throw InputError(source, 0,
                     "frames " + std::to_string(first) + "-" + std::to_string(last) +
                         " outside the clip's 0-" + std::to_string(frames ? frames - 1 : 0));
}

// The pelvis' world rotation with the heading taken out (style_heading_rad).
Eigen::Quaterniond without_heading(const Eigen::Quaterniond& q) {
  return (Eigen::AngleAxisd(-style_heading_rad(q), Eigen::Vector3d::UnitY()) * q).normalized();
}

double percentile90(std::vector<double> v) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  // Linear between order statistics, as numpy's default.
  const double at = 0.9 * static_cast<double>(v.size() - 1);
  const auto lo = static_cast<std::size_t>(std::floor(at));
  const std::size_t hi = std::min(lo + 1, v.size() - 1);
  return v[lo] + (at - static_cast<double>(lo)) * (v[hi] - v[lo]);
}

// One joint's features (kStyleJointFeatures) from its per-frame rotations.
void joint_features(const std::vector<Eigen::Quaterniond>& q, double dt, std::vector<double>& out) {
  const std::size_t n = q.size();
  std::vector<Eigen::Vector3d> rv(n);
  for (std::size_t f = 0; f < n; ++f) rv[f] = style_rotation_vector(q[f]);
  Eigen::Vector3d mean = Eigen::Vector3d::Zero(), sq = Eigen::Vector3d::Zero();
  for (const Eigen::Vector3d& v : rv) mean += v;
  mean /= static_cast<double>(n);
  for (const Eigen::Vector3d& v : rv) sq += (v - mean).cwiseAbs2();
  const Eigen::Vector3d sd = (sq / static_cast<double>(n)).cwiseSqrt();
  out.insert(out.end(), {mean.x(), mean.y(), mean.z(), sd.x(), sd.y(), sd.z()});
  std::vector<double> speed(n - 1);
  for (std::size_t f = 0; f + 1 < n; ++f)
    speed[f] = style_rotation_vector(q[f].conjugate() * q[f + 1]).norm() / dt;
  out.push_back(std::accumulate(speed.begin(), speed.end(), 0.0) / static_cast<double>(n - 1));
  out.push_back(percentile90(speed));
  double acc = 0.0;
  for (std::size_t f = 1; f + 1 < n; ++f) acc += (rv[f + 1] - 2.0 * rv[f] + rv[f - 1]).norm();
  out.push_back(std::log1p(acc / static_cast<double>(n - 2) / (dt * dt)));
}

// Mean and population standard deviation of rows `rows` of x (+1e-6 on the
// spread, so that a constant feature standardises to 0).
void mean_sd(const Eigen::MatrixXd& x, const std::vector<std::size_t>& rows, Eigen::VectorXd& mean,
             Eigen::VectorXd& sd) {
  mean = Eigen::VectorXd::Zero(x.cols());
  for (std::size_t r : rows) mean += x.row(static_cast<Eigen::Index>(r)).transpose();
  mean /= static_cast<double>(rows.size());
  Eigen::VectorXd sq = Eigen::VectorXd::Zero(x.cols());
  for (std::size_t r : rows)
    sq += (x.row(static_cast<Eigen::Index>(r)).transpose() - mean).cwiseAbs2();
  sd = (sq / static_cast<double>(rows.size())).cwiseSqrt().array() + 1e-6;
}

// The discriminant of rows z (standardised) with class labels.
StyleDiscriminant fit_discriminant(const Eigen::MatrixXd& z, const std::vector<std::string>& labels,
                                   double shrinkage) {
  StyleDiscriminant d;
  const std::set<std::string> classes(labels.begin(), labels.end());
  d.classes.assign(classes.begin(), classes.end());
  const auto k = static_cast<Eigen::Index>(d.classes.size());
  const Eigen::Index dims = z.cols();
  d.means = Eigen::MatrixXd::Zero(k, dims);
  std::vector<double> counts(d.classes.size(), 0.0);
  std::vector<Eigen::Index> of(labels.size());
  for (std::size_t i = 0; i < labels.size(); ++i) {
    of[i] = std::lower_bound(d.classes.begin(), d.classes.end(), labels[i]) - d.classes.begin();
    d.means.row(of[i]) += z.row(static_cast<Eigen::Index>(i));
    counts[static_cast<std::size_t>(of[i])] += 1.0;
  }
  for (Eigen::Index c = 0; c < k; ++c) d.means.row(c) /= counts[static_cast<std::size_t>(c)];
  Eigen::MatrixXd centred = z;
  for (std::size_t i = 0; i < labels.size(); ++i)
    centred.row(static_cast<Eigen::Index>(i)) -= d.means.row(of[i]);
  Eigen::MatrixXd w = centred.transpose() * centred / static_cast<double>(z.rows());
  const double mean_variance = w.trace() / static_cast<double>(dims);
  w = (1.0 - shrinkage) * w;
  w.diagonal().array() += shrinkage * mean_variance;
  d.precision = w.ldlt().solve(Eigen::MatrixXd::Identity(dims, dims));
  return d;
}

Eigen::VectorXd as_vector(const std::vector<double>& f) {
  return Eigen::Map<const Eigen::VectorXd>(f.data(), static_cast<Eigen::Index>(f.size()));
}

// Whether the motion's skeleton has every one of `joints`.
bool has_joints(const StyleMotion& m, const std::vector<std::string>& joints) {
  return std::all_of(joints.begin(), joints.end(), [&](const std::string& j) {
    return std::find(m.joint_names.begin(), m.joint_names.end(), j) != m.joint_names.end();
  });
}

std::size_t feature_count(const std::vector<std::string>& joints) {
  return joints.size() * kStyleJointFeatures + kStyleMotionFeatures;
}

}  // namespace

Eigen::Vector3d style_rotation_vector(const Eigen::Quaterniond& q) {
  const double s = q.vec().norm();
  const double w = q.w() < 0.0 ? -q.w() : q.w();
  const Eigen::Vector3d v = q.w() < 0.0 ? Eigen::Vector3d(-q.vec()) : Eigen::Vector3d(q.vec());
  if (s < 1e-12) return 2.0 * v;
  return (2.0 * std::atan2(s, w) / s) * v;
}

double style_heading_rad(const Eigen::Quaterniond& q) {
  Eigen::Vector3d f = q * Eigen::Vector3d::UnitZ();
  if (std::hypot(f.x(), f.z()) < 1e-6) f = q * Eigen::Vector3d::UnitX();
  return std::atan2(f.x(), f.z());
}

StyleMotion index_style_motion(const Index& index, std::size_t clip, std::size_t first,
                               std::size_t last) {
  const IndexClip& c = index.clips().at(clip);
  check_range(c.path, c.frame_count, first, last);
  const IndexSkeleton& isk = index.skeletons()[c.skeleton];
  StyleMotion m;
  m.joint_names = isk.skeleton.names;
  m.parents = isk.skeleton.parents;
  m.pelvis = isk.root_joint;
  m.frame_time_s = c.frame_time_s;
  m.frame_count = last - first + 1;
  const std::size_t joints = m.joint_names.size();
  const std::span<const float> local = index.clip_frames(clip, "local_rotations");
  const std::span<const float> world = index.clip_frames(clip, "world_rotations");
  const std::span<const float> root = index.clip_frames(clip, "root_position_m");
  const auto p = static_cast<std::size_t>(m.pelvis);
  for (std::size_t f = first; f <= last; ++f) {
    for (std::size_t j = 0; j < joints; ++j) {
      const float* q = local.data() + (f * joints + j) * 4;
      m.local_rotations.emplace_back(q[0], q[1], q[2], q[3]);
      m.local_rotations.back().normalize();
    }
    const float* w = world.data() + (f * joints + p) * 4;
    m.pelvis_rotations.push_back(Eigen::Quaterniond(w[0], w[1], w[2], w[3]).normalized());
    m.pelvis_positions.emplace_back(root[f * 3], root[f * 3 + 1], root[f * 3 + 2]);
  }
  return m;
}

StyleMotion raw_style_motion(const RawClip& clip, std::size_t first, std::size_t last) {
  check_range(clip.source, clip.frame_count, first, last);
  const Skeleton skel = build_skeleton(clip, 1.0);
  const Body body = build_body(skel, Character{});
  StyleMotion m;
  m.joint_names = skel.names;
  m.parents = skel.parents;
  m.pelvis = std::max(0, build_dynamics_model(skel, body).root());
  m.frame_time_s = clip.frame_time_s;
  m.frame_count = last - first + 1;
  LocalPose local;
  WorldPose world;
  const auto p = static_cast<std::size_t>(m.pelvis);
  for (std::size_t f = first; f <= last; ++f) {
    local_pose_from_row(skel, clip.frame(f), local);
    forward_kinematics(skel, local, world);
    m.local_rotations.insert(m.local_rotations.end(), local.rotations.begin(),
                             local.rotations.end());
    m.pelvis_rotations.push_back(world.rotations[p]);
    m.pelvis_positions.push_back(world.positions_m[p]);
  }
  return m;
}

std::vector<std::string> style_joints(const StyleMotion& m) {
  std::vector<std::string> out;
  std::vector<std::uint8_t> below(m.joint_names.size(), 0);
  for (std::size_t j = 0; j < m.joint_names.size(); ++j) {
    const int parent = m.parents[j];
    below[j] =
        static_cast<int>(j) == m.pelvis || (parent >= 0 && below[static_cast<std::size_t>(parent)]);
    if (below[j]) out.push_back(m.joint_names[j]);
  }
  return out;
}

std::vector<double> style_features(const StyleMotion& m, const std::vector<std::string>& joints) {
  const std::string src = "<style features>";
  if (m.frame_count < 4)
    throw InputError(
        src, 0,
        "a motion of " + std::to_string(m.frame_count) + " frames: style features need at least 4");
  if (!(m.frame_time_s > 0.0)) throw InputError(src, 0, "the frame time must be positive");
  const std::size_t n = m.frame_count, count = m.joint_names.size();
  std::vector<double> out;
  out.reserve(feature_count(joints));
  std::vector<Eigen::Quaterniond> q(n);
  for (const std::string& name : joints) {
    const auto it = std::find(m.joint_names.begin(), m.joint_names.end(), name);
    if (it == m.joint_names.end())
      throw InputError(src, 0, "the motion's skeleton has no joint \"" + name + "\"");
    const auto j = static_cast<std::size_t>(it - m.joint_names.begin());
    for (std::size_t f = 0; f < n; ++f)
      q[f] = static_cast<int>(j) == m.pelvis ? without_heading(m.pelvis_rotations[f])
                                             : m.local_rotations[f * count + j];
    joint_features(q, m.frame_time_s, out);
  }
  std::vector<double> heights(n);
  for (std::size_t f = 0; f < n; ++f) heights[f] = m.pelvis_positions[f].y();
  std::vector<double> sorted = heights;
  std::nth_element(sorted.begin(), sorted.begin() + static_cast<std::ptrdiff_t>(n / 2),
                   sorted.end());
  const double median = sorted[n / 2];
  if (!(median > 0.0)) throw InputError(src, 0, "the pelvis is not above the ground (Y up)");
  double ground = 0.0, mean_h = 0.0, sq = 0.0;
  for (std::size_t f = 0; f + 1 < n; ++f) {
    const Eigen::Vector3d d = m.pelvis_positions[f + 1] - m.pelvis_positions[f];
    ground += std::hypot(d.x(), d.z()) / m.frame_time_s;
  }
  for (double h : heights) mean_h += h / static_cast<double>(n);
  for (double h : heights) sq += (h - mean_h) * (h - mean_h);
  out.push_back(ground / static_cast<double>(n - 1) / median);
  out.push_back(std::sqrt(sq / static_cast<double>(n)) / median);
  out.push_back(std::log(static_cast<double>(n) * m.frame_time_s));
  for (double v : out)
    if (!std::isfinite(v)) throw InputError(src, 0, "a feature is not finite");
  return out;
}

Eigen::VectorXd StyleDiscriminant::scores(const Eigen::VectorXd& z) const {
  Eigen::VectorXd s(means.rows());
  for (Eigen::Index c = 0; c < means.rows(); ++c) {
    const Eigen::VectorXd d = z - means.row(c).transpose();
    s(c) = -0.5 * d.dot(precision * d);
  }
  return s;
}

std::vector<StyleSample> index_style_samples(const Index& index, std::vector<std::string>& joints) {
  std::vector<StyleSample> out;
  joints.clear();
  for (std::size_t c = 0; c < index.clips().size(); ++c) {
    StyleSample s;
    s.content = index.label(c, "content");
    s.style = index.label(c, "style");
    if (s.content.empty() || s.style.empty() || index.clips()[c].frame_count < 4) continue;
    const StyleMotion m = index_style_motion(index, c, 0, index.clips()[c].frame_count - 1);
    if (joints.empty()) joints = style_joints(m);
    if (!has_joints(m, joints)) continue;
    s.features = style_features(m, joints);
    s.clip = c;
    out.push_back(std::move(s));
  }
  if (out.empty())
    throw InputError(index.path().string(), 0,
                     "no clip has both a \"content\" and a \"style\" label (docs/style.md)");
  return out;
}

StyleModel train_style_model(const std::vector<StyleSample>& samples,
                             const std::vector<std::string>& joints, double shrinkage) {
  const std::string src = "<style model>";
  const std::size_t dims = feature_count(joints);
  if (!(shrinkage > 0.0 && shrinkage <= 1.0))
    throw InputError(src, 0, "the shrinkage must be in (0, 1]");
  std::set<std::string> styles;
  for (const StyleSample& s : samples) {
    if (s.features.size() != dims)
      throw InputError(src, 0,
                       "a sample has " + std::to_string(s.features.size()) +
                           " features, the joints give " + std::to_string(dims));
    styles.insert(s.style);
  }
  if (styles.size() < 2)
    throw InputError(src, 0,
                     "the labelled clips have " + std::to_string(styles.size()) +
                         " style(s): a model needs at least 2");
  StyleModel m;
  m.joints = joints;
  m.shrinkage = shrinkage;
  m.clips = samples.size();
  Eigen::MatrixXd x(static_cast<Eigen::Index>(samples.size()), static_cast<Eigen::Index>(dims));
  std::vector<std::string> contents(samples.size()), labels(samples.size());
  for (std::size_t i = 0; i < samples.size(); ++i) {
    x.row(static_cast<Eigen::Index>(i)) = as_vector(samples[i].features).transpose();
    contents[i] = samples[i].content;
    labels[i] = samples[i].style;
  }
  std::vector<std::size_t> all(samples.size());
  std::iota(all.begin(), all.end(), std::size_t{0});
  mean_sd(x, all, m.all_mean, m.all_sd);
  Eigen::MatrixXd zc =
      (x.rowwise() - m.all_mean.transpose()).array().rowwise() / m.all_sd.transpose().array();
  m.content = fit_discriminant(zc, contents, shrinkage);
  const auto k = static_cast<Eigen::Index>(m.content.classes.size());
  m.content_mean.resize(k, static_cast<Eigen::Index>(dims));
  m.content_sd.resize(k, static_cast<Eigen::Index>(dims));
  Eigen::MatrixXd z(x.rows(), x.cols());
  for (Eigen::Index c = 0; c < k; ++c) {
    std::vector<std::size_t> rows;
    for (std::size_t i = 0; i < samples.size(); ++i)
      if (contents[i] == m.content.classes[static_cast<std::size_t>(c)]) rows.push_back(i);
    Eigen::VectorXd mean, sd;
    mean_sd(x, rows, mean, sd);
    m.content_mean.row(c) = mean.transpose();
    m.content_sd.row(c) = sd.transpose();
    for (std::size_t r : rows)
      z.row(static_cast<Eigen::Index>(r)) =
          ((x.row(static_cast<Eigen::Index>(r)).transpose() - mean).array() / sd.array())
              .transpose();
  }
  Eigen::VectorXd zero;
  mean_sd(z, all, zero, m.style_scale);
  z = z.array().rowwise() / m.style_scale.transpose().array();
  m.style = fit_discriminant(z, labels, shrinkage);
  return m;
}

StylePrediction recognise_style(const StyleModel& model, const std::vector<double>& features,
                                const std::string& content) {
  const std::string src = "<style model>";
  if (features.size() != static_cast<std::size_t>(model.all_mean.size()))
    throw InputError(src, 0,
                     std::to_string(features.size()) + " features, the model has " +
                         std::to_string(model.all_mean.size()));
  const Eigen::VectorXd x = as_vector(features);
  StylePrediction p;
  std::size_t c = 0;
  if (content.empty()) {
    const Eigen::VectorXd zc = ((x - model.all_mean).array() / model.all_sd.array()).matrix();
    Eigen::Index best = 0;
    model.content.scores(zc).maxCoeff(&best);
    c = static_cast<std::size_t>(best);
    p.content_recognised = true;
  } else {
    const auto it = std::find(model.content.classes.begin(), model.content.classes.end(), content);
    if (it == model.content.classes.end())
      throw InputError(src, 0, "the model has no content \"" + content + "\"");
    c = static_cast<std::size_t>(it - model.content.classes.begin());
  }
  p.content = model.content.classes[c];
  const auto row = static_cast<Eigen::Index>(c);
  const Eigen::VectorXd z =
      ((x - model.content_mean.row(row).transpose()).array() /
       model.content_sd.row(row).transpose().array() / model.style_scale.array())
          .matrix();
  const Eigen::VectorXd s = model.style.scores(z) / model.temperature;
  Eigen::Index best = 0;
  const double top = s.maxCoeff(&best);
  const Eigen::VectorXd e = (s.array() - top).exp();
  const double total = e.sum();
  p.style = model.style.classes[static_cast<std::size_t>(best)];
  p.probability = e(best) / total;
  for (std::size_t i = 0; i < model.style.classes.size(); ++i)
    p.probabilities.emplace_back(model.style.classes[i], e(static_cast<Eigen::Index>(i)) / total);
  return p;
}

std::optional<StylePrediction> recognise_motion_style(const StyleModel& model,
                                                      const StyleMotion& motion,
                                                      const std::string& content_label) {
  if (motion.frame_count < 4 || !has_joints(motion, model.joints)) return std::nullopt;
  const bool known = std::find(model.content.classes.begin(), model.content.classes.end(),
                               content_label) != model.content.classes.end();
  return recognise_style(model, style_features(motion, model.joints),
                         known ? content_label : std::string());
}

StyleMotion bvh_style_motion(const std::filesystem::path& file,
                             std::optional<std::pair<std::size_t, std::size_t>> frames,
                             std::optional<UpAxis> up) {
  RawClip clip = read_bvh_file(file);
  normalise_up_axis(clip, up);
  const std::size_t last = clip.frame_count ? clip.frame_count - 1 : 0;
  const auto [s, e] = frames.value_or(std::pair<std::size_t, std::size_t>{0, last});
  return raw_style_motion(clip, s, e);
}

nlohmann::json style_prediction_json(const std::string& file, std::size_t first, std::size_t last,
                                     const StylePrediction& p) {
  nlohmann::json probs = nlohmann::json::object();
  for (const auto& [style, prob] : p.probabilities) probs[style] = prob;
  return {{"file", file},         {"frames", {first, last}},
          {"style", p.style},     {"probabilities", probs},
          {"content", p.content}, {"content_recognised", p.content_recognised}};
}

namespace {

nlohmann::json matrix_json(const Eigen::MatrixXd& m) {
  nlohmann::json rows = nlohmann::json::array();
  for (Eigen::Index r = 0; r < m.rows(); ++r) {
    std::vector<double> row(static_cast<std::size_t>(m.cols()));
    for (Eigen::Index c = 0; c < m.cols(); ++c) row[static_cast<std::size_t>(c)] = m(r, c);
    rows.push_back(row);
  }
  return rows;
}

nlohmann::json discriminant_json(const StyleDiscriminant& d) {
  return {{"classes", d.classes},
          {"means", matrix_json(d.means)},
          {"precision", matrix_json(d.precision)}};
}

const nlohmann::json& field(const nlohmann::json& j, const char* name, const std::string& where,
                            const std::string& source) {
  if (!j.is_object() || !j.contains(name))
    throw InputError(source, 0, "missing \"" + where + name + "\" (a style model: docs/style.md)");
  return j.at(name);
}

Eigen::MatrixXd matrix_from(const nlohmann::json& j, Eigen::Index rows, Eigen::Index cols,
                            const std::string& name, const std::string& source) {
  if (!j.is_array() || static_cast<Eigen::Index>(j.size()) != rows)
    throw InputError(source, 0, "\"" + name + "\": " + std::to_string(rows) + " rows expected");
  Eigen::MatrixXd m(rows, cols);
  for (Eigen::Index r = 0; r < rows; ++r) {
    const nlohmann::json& row = j[static_cast<std::size_t>(r)];
    if (!row.is_array() || static_cast<Eigen::Index>(row.size()) != cols)
      throw InputError(source, 0,
                       "\"" + name + "\" row " + std::to_string(r) + ": " + std::to_string(cols) +
                           " numbers expected");
    for (Eigen::Index c = 0; c < cols; ++c) {
      const nlohmann::json& v = row[static_cast<std::size_t>(c)];
      if (!v.is_number()) throw InputError(source, 0, "\"" + name + "\": a value is not a number");
      m(r, c) = v.get<double>();
    }
  }
  return m;
}

StyleDiscriminant discriminant_from(const nlohmann::json& j, const std::string& name,
                                    Eigen::Index dims, const std::string& source) {
  StyleDiscriminant d;
  const nlohmann::json& classes = field(j, "classes", name + ".", source);
  if (!classes.is_array() || classes.empty())
    throw InputError(source, 0, "\"" + name + ".classes\": a list of names expected");
  for (const nlohmann::json& c : classes) {
    if (!c.is_string()) throw InputError(source, 0, "\"" + name + ".classes\": names expected");
    d.classes.push_back(c.get<std::string>());
  }
  const auto k = static_cast<Eigen::Index>(d.classes.size());
  d.means = matrix_from(field(j, "means", name + ".", source), k, dims, name + ".means", source);
  d.precision = matrix_from(field(j, "precision", name + ".", source), dims, dims,
                            name + ".precision", source);
  return d;
}

}  // namespace

nlohmann::json style_model_json(const StyleModel& m) {
  const auto vec = [](const Eigen::VectorXd& v) { return std::vector<double>(v.begin(), v.end()); };
  return {{"format", "mocap-style-model"},
          {"version", 1},
          {"joints", m.joints},
          {"shrinkage", m.shrinkage},
          {"clips", m.clips},
          {"temperature", m.temperature},
          {"all_mean", vec(m.all_mean)},
          {"all_sd", vec(m.all_sd)},
          {"style_scale", vec(m.style_scale)},
          {"content_mean", matrix_json(m.content_mean)},
          {"content_sd", matrix_json(m.content_sd)},
          {"content", discriminant_json(m.content)},
          {"style", discriminant_json(m.style)}};
}

StyleModel style_model_from_json(const nlohmann::json& j, const std::string& source) {
  if (field(j, "format", "", source) != "mocap-style-model" || field(j, "version", "", source) != 1)
    throw InputError(source, 0,
                     "not a style model of version 1 (\"format\": \"mocap-style-model\")");
  StyleModel m;
  const nlohmann::json& joints = field(j, "joints", "", source);
  if (!joints.is_array() || joints.empty())
    throw InputError(source, 0, "\"joints\": a list of joint names expected");
  for (const nlohmann::json& n : joints) {
    if (!n.is_string()) throw InputError(source, 0, "\"joints\": names expected");
    m.joints.push_back(n.get<std::string>());
  }
  const auto dims = static_cast<Eigen::Index>(feature_count(m.joints));
  const auto vec = [&](const char* name) -> Eigen::VectorXd {
    return matrix_from(nlohmann::json::array({field(j, name, "", source)}), 1, dims, name, source)
        .row(0)
        .transpose();
  };
  m.all_mean = vec("all_mean");
  m.all_sd = vec("all_sd");
  m.style_scale = vec("style_scale");
  const nlohmann::json& shrink = field(j, "shrinkage", "", source);
  const nlohmann::json& clips = field(j, "clips", "", source);
  if (!shrink.is_number() || !clips.is_number_unsigned())
    throw InputError(source, 0, "\"shrinkage\" and \"clips\" must be numbers");
  m.shrinkage = shrink.get<double>();
  m.clips = clips.get<std::size_t>();
  if (j.contains("temperature")) {  // absent: 1 (a model without calibration)
    const nlohmann::json& t = j.at("temperature");
    if (!t.is_number() || !(t.get<double>() > 0.0))
      throw InputError(source, 0, "\"temperature\" must be a positive number");
    m.temperature = t.get<double>();
  }
  m.content = discriminant_from(field(j, "content", "", source), "content", dims, source);
  m.style = discriminant_from(field(j, "style", "", source), "style", dims, source);
  const auto k = static_cast<Eigen::Index>(m.content.classes.size());
  m.content_mean =
      matrix_from(field(j, "content_mean", "", source), k, dims, "content_mean", source);
  m.content_sd = matrix_from(field(j, "content_sd", "", source), k, dims, "content_sd", source);
  return m;
}

namespace {

// Cross-validation: fn(model, sample) for each sample held out of a model
// learned without it (sample i in fold i % k; k = 0: one fold a sample)
// whose content the model knows; returns how many it did not know.
std::size_t for_held_out(const std::vector<StyleSample>& samples,
                         const std::vector<std::string>& joints, std::size_t folds,
                         double shrinkage,
                         const std::function<void(const StyleModel&, const StyleSample&)>& fn) {
  std::size_t alone = 0;
  const std::size_t k = folds == 0 ? samples.size() : folds;
  for (std::size_t fold = 0; fold < k; ++fold) {
    std::vector<StyleSample> train;
    std::vector<const StyleSample*> test;
    for (std::size_t i = 0; i < samples.size(); ++i)
      (i % k == fold ? test.push_back(&samples[i]) : train.push_back(samples[i]));
    if (test.empty()) continue;
    const StyleModel m = train_style_model(train, joints, shrinkage);
    for (const StyleSample* s : test) {
      if (std::find(m.content.classes.begin(), m.content.classes.end(), s->content) ==
          m.content.classes.end()) {
        ++alone;
        continue;
      }
      fn(m, *s);
    }
  }
  return alone;
}

// Mean log-probability of the true classes of score rows at temperature t.
double mean_log_probability(const std::vector<std::pair<Eigen::VectorXd, Eigen::Index>>& rows,
                            double t) {
  double sum = 0.0;
  for (const auto& [s, truth] : rows) {
    const Eigen::VectorXd z = s / t;
    const double top = z.maxCoeff();
    sum += z(truth) - top - std::log((z.array() - top).exp().sum());
  }
  return sum / static_cast<double>(rows.size());
}

}  // namespace

StyleEvaluation evaluate_style(const std::vector<StyleSample>& samples,
                               const std::vector<std::string>& joints, std::size_t folds,
                               double shrinkage) {
  StyleEvaluation e;
  e.alone = for_held_out(samples, joints, folds, shrinkage,
                         [&](const StyleModel& m, const StyleSample& s) {
                           const StylePrediction p = recognise_style(m, s.features, s.content);
                           ++e.takes;
                           e.right += p.style == s.style ? 1 : 0;
                           ++e.confusion[{s.style, p.style}];
                         });
  return e;
}

nlohmann::json style_evaluation_json(const StyleEvaluation& e, std::size_t folds) {
  std::map<std::string, std::map<std::string, std::size_t>> confusion;
  for (const auto& [pair, n] : e.confusion) confusion[pair.first][pair.second] = n;
  return {{"folds", folds},           {"takes", e.takes}, {"right", e.right},
          {"accuracy", e.accuracy()}, {"alone", e.alone}, {"confusion", confusion}};
}

double calibrate_style_temperature(const std::vector<StyleSample>& samples,
                                   const std::vector<std::string>& joints, std::size_t folds,
                                   double shrinkage) {
  std::map<std::string, std::size_t> takes;
  for (const StyleSample& s : samples) ++takes[s.content];
  std::vector<std::pair<Eigen::VectorXd, Eigen::Index>> rows;
  for_held_out(samples, joints, folds, shrinkage, [&](const StyleModel& m, const StyleSample& s) {
    const auto truth = std::find(m.style.classes.begin(), m.style.classes.end(), s.style);
    if (truth == m.style.classes.end()) return;  // a style no training take has
    if (takes[s.content] < kStyleCalibrationTakes) return;
    const auto c = static_cast<Eigen::Index>(
        std::find(m.content.classes.begin(), m.content.classes.end(), s.content) -
        m.content.classes.begin());
    const Eigen::VectorXd z = ((as_vector(s.features) - m.content_mean.row(c).transpose()).array() /
                               m.content_sd.row(c).transpose().array() / m.style_scale.array())
                                  .matrix();
    rows.emplace_back(m.style.scores(z), truth - m.style.classes.begin());
  });
  if (rows.empty()) return 1.0;
  // Golden-section search of the concave mean log-probability over log T.
  const double g = (std::sqrt(5.0) - 1.0) / 2.0;
  double a = std::log(0.01), b = std::log(1e4);
  double x1 = b - g * (b - a), x2 = a + g * (b - a);
  double f1 = mean_log_probability(rows, std::exp(x1)),
         f2 = mean_log_probability(rows, std::exp(x2));
  for (int it = 0; it < 80; ++it) {
    if (f1 < f2) {
      a = x1;
      x1 = x2;
      f1 = f2;
      x2 = a + g * (b - a);
      f2 = mean_log_probability(rows, std::exp(x2));
    } else {
      b = x2;
      x2 = x1;
      f2 = f1;
      x1 = b - g * (b - a);
      f1 = mean_log_probability(rows, std::exp(x1));
    }
  }
  return std::exp(0.5 * (a + b));
}

StyleModel learn_style_model(const std::vector<StyleSample>& samples,
                             const std::vector<std::string>& joints, double shrinkage) {
  StyleModel m = train_style_model(samples, joints, shrinkage);
  m.temperature = calibrate_style_temperature(samples, joints, 5, shrinkage);
  return m;
}

}  // namespace mocap
