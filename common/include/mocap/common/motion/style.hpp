#pragma once
// Style of a motion (docs/style.md): features of a clip's joint rotations
// and root path, and linear discriminants over them learned from an index's
// labelled clips (labels "content" and "style"), which name the style of a
// clip, a frame range or a file. No length enters the features: Bandai
// Namco's performers differ in proportions and each performs its own
// styles, so positions would learn who performed a take
// (docs/experiments/2026-12-06-style-recognition.md).
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstddef>
#include <filesystem>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "mocap/common/io/index.hpp"
#include "mocap/common/io/raw_clip.hpp"
#include "mocap/common/io/units.hpp"

namespace mocap {

/// A motion as the style features read it: joint names and parents, the
/// pelvis (the character's root: an index skeleton's root_joint, a file's
/// first body root), and per frame every joint's local rotation and the
/// pelvis' world rotation and position (Y up; any length unit: the features
/// use only ratios of lengths).
struct StyleMotion {
  std::vector<std::string> joint_names;
  std::vector<int> parents;
  int pelvis = 0;
  double frame_time_s = 0.0;
  std::size_t frame_count = 0;
  std::vector<Eigen::Quaterniond> local_rotations;   // frame_count x joints, row-major
  std::vector<Eigen::Quaterniond> pelvis_rotations;  // frame_count
  std::vector<Eigen::Vector3d> pelvis_positions;     // frame_count
};

/// Frames first..last (0-based, inclusive) of clip `clip` of `index`.
/// Throws InputError when the range is empty or runs past the clip.
StyleMotion index_style_motion(const Index& index, std::size_t clip, std::size_t first,
                               std::size_t last);
/// Frames first..last of a clip read from a file (Y up: normalise_up_axis
/// first); its pelvis is the first body root of the default character.
/// Throws InputError as index_style_motion does.
StyleMotion raw_style_motion(const RawClip& clip, std::size_t first, std::size_t last);

/// The joints whose rotations are features: the pelvis, then every joint
/// below it, in skeleton order (joints above the pelvis, such as Bandai
/// Namco's static joint_Root, carry no motion).
std::vector<std::string> style_joints(const StyleMotion& m);

/// The rotation vector the features read (axis times angle, the angle in
/// [0, pi], radians) of a unit quaternion.
Eigen::Vector3d style_rotation_vector(const Eigen::Quaterniond& q);
/// The heading the features take out of the pelvis' world rotation q
/// (radians about +Y): the pelvis' local +Z (its forward axis in Bandai
/// Namco's and CMU's rigs) turned onto the ground plane, local +X where +Z is
/// vertical. The features read R_y(-heading) q.
double style_heading_rad(const Eigen::Quaterniond& q);

/// Features per joint and of the whole motion.
inline constexpr std::size_t kStyleJointFeatures = 9;
inline constexpr std::size_t kStyleMotionFeatures = 3;

/// The features of `m` for `joints` (names, in that order): per joint its
/// rotation vector's mean (3, radians) and standard deviation (3) over the
/// frames (the pelvis: its world rotation with the heading taken out, the
/// others their local rotation), the mean and the 90th percentile of its
/// angular speed between frames (rad/s) and log(1 + mean angular
/// acceleration) (rad/s^2, from second differences of the rotation
/// vector); then the pelvis' mean ground speed over its median height (1/s),
/// the standard deviation of its height over its median height, and the
/// log of the duration (s). Throws InputError naming a joint that `m` lacks,
/// for fewer than 4 frames, or for a pelvis not above the ground.
std::vector<double> style_features(const StyleMotion& m, const std::vector<std::string>& joints);

/// A linear discriminant: class means and the inverse of the pooled
/// within-class covariance (shrunk toward its mean variance), on
/// standardised features.
struct StyleDiscriminant {
  std::vector<std::string> classes;
  Eigen::MatrixXd means;      // classes x features
  Eigen::MatrixXd precision;  // features x features
  /// -1/2 the squared Mahalanobis distance to each class mean.
  Eigen::VectorXd scores(const Eigen::VectorXd& z) const;
};

/// A labelled clip's features.
struct StyleSample {
  std::vector<double> features;
  std::string content, style;
  std::size_t clip = 0;
};

/// What `mocap-index style-model` writes (docs/style.md "The model").
struct StyleModel {
  std::vector<std::string> joints;
  double shrinkage = 0.3;
  std::size_t clips = 0;
  /// The style scores are divided by it before the softmax
  /// (calibrate_style_temperature; 1 = the discriminant's own).
  double temperature = 1.0;
  /// Per content: the mean and spread of its clips' features (rows in
  /// content.classes order).
  Eigen::MatrixXd content_mean, content_sd;
  /// Over every clip: mean and spread (the content discriminant's input).
  Eigen::VectorXd all_mean, all_sd;
  /// Spread of the content-standardised features (the style discriminant
  /// divides by it).
  Eigen::VectorXd style_scale;
  StyleDiscriminant content, style;
};

/// The labelled clips of `index` (both labels set), whole, on the joints of
/// the first such clip's skeleton (`joints` is set to them); clips of a
/// skeleton lacking one of them are left out. Throws InputError when no
/// clip has both labels.
std::vector<StyleSample> index_style_samples(const Index& index, std::vector<std::string>& joints);

/// Learns the model. Throws InputError for fewer than 2 styles, a style or
/// content with no clip, or features of the wrong length.
StyleModel train_style_model(const std::vector<StyleSample>& samples,
                             const std::vector<std::string>& joints, double shrinkage = 0.3);

struct StylePrediction {
  std::string style;
  /// The content whose statistics standardised the features: given, or
  /// recognised by the content discriminant.
  std::string content;
  bool content_recognised = false;
  /// Every style of the model with its probability (softmax of the
  /// discriminant's scores over the model's temperature), in the model's
  /// style order.
  std::vector<std::pair<std::string, double>> probabilities;
  /// The probability of `style`.
  double probability = 0.0;
};
/// The style of features from style_features(motion, model.joints); an
/// empty `content` is recognised first. Throws InputError for a content the
/// model does not know or features of the wrong length.
StylePrediction recognise_style(const StyleModel& model, const std::vector<double>& features,
                                const std::string& content = "");

/// The style of a motion the model may not be able to read: nullopt for
/// fewer than 4 frames or a skeleton lacking one of the model's joints.
/// `content_label` (a clip's label; may be empty) standardises the features
/// when the model knows that content; otherwise the content is recognised.
std::optional<StylePrediction> recognise_motion_style(const StyleModel& model,
                                                      const StyleMotion& motion,
                                                      const std::string& content_label);

/// Frames `frames` (default: all) of a BVH file, Y up (`up`: declared, or
/// detected), as raw_style_motion reads them.
StyleMotion bvh_style_motion(const std::filesystem::path& file,
                             std::optional<std::pair<std::size_t, std::size_t>> frames,
                             std::optional<UpAxis> up = std::nullopt);

/// What `mocap-search style --json` prints for frames first..last of `file`
/// (docs/style.md "Recognising a motion").
nlohmann::json style_prediction_json(const std::string& file, std::size_t first, std::size_t last,
                                     const StylePrediction& p);

nlohmann::json style_model_json(const StyleModel& model);
/// Throws InputError(source, 0, ...) naming the field that is missing or wrong.
StyleModel style_model_from_json(const nlohmann::json& j, const std::string& source);

/// Cross-validation of train_style_model on `samples`: folds 0 = leave one
/// take out, otherwise sample i in fold i % folds. A held-out take is
/// standardised by its own content's statistics from the training takes;
/// one whose content has no training take is counted in `alone`, not in
/// `takes`.
struct StyleEvaluation {
  std::size_t takes = 0, right = 0, alone = 0;
  /// (true style, named style) -> takes.
  std::map<std::pair<std::string, std::string>, std::size_t> confusion;
  double accuracy() const { return takes ? static_cast<double>(right) / takes : 0.0; }
};
StyleEvaluation evaluate_style(const std::vector<StyleSample>& samples,
                               const std::vector<std::string>& joints, std::size_t folds,
                               double shrinkage = 0.3);
/// The "evaluation" object of `mocap-index style-model --evaluate --json`.
nlohmann::json style_evaluation_json(const StyleEvaluation& e, std::size_t folds);

inline constexpr std::size_t kStyleCalibrationTakes = 10;

/// What `mocap-index style-model` and Python's Index.style_model learn:
/// train_style_model, its temperature from calibrate_style_temperature
/// with 5 folds.
StyleModel learn_style_model(const std::vector<StyleSample>& samples,
                             const std::vector<std::string>& joints, double shrinkage = 0.3);

/// The temperature T that makes the style probabilities honest: the style
/// scores of held-out takes (sample i held out in fold i % folds, its
/// content given, as evaluate_style) divided by T, T maximising the mean
/// log-probability of their true styles (golden-section search on log T in
/// [0.01, 10^4]). A linear discriminant in many dimensions is
/// overconfident: T > 1. Only takes of contents with at least
/// kStyleCalibrationTakes takes count (a content of 2 takes, one held out,
/// is standardised by a spread of nothing, and one such take would drive T
/// to its bound); with none, 1.
double calibrate_style_temperature(const std::vector<StyleSample>& samples,
                                   const std::vector<std::string>& joints, std::size_t folds = 5,
                                   double shrinkage = 0.3);

}  // namespace mocap
