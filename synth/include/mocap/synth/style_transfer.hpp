#pragma once
// Style transfer (docs/style.md "Style transfer"): turns a synthesised
// motion toward a style of a style model, even one the database lacks for
// the motion's content, with no neural network: a per-joint linear map of
// the joints' rotation vectors in the spirit of Hsu, Pulli and Popovic,
// "Style translation for human motion" (SIGGRAPH 2005), whose target is what
// the model predicts for the motion's content in the asked style.
//
// The model (mocap/common/motion/style.hpp) stores, per content C, each
// feature's mean and spread over C's clips, and per style S its class mean in
// content-standardised space, so the feature f of "C in style S" is predicted
// as content_mean[C][f] + means[S][f] style_scale[f] content_sd[C][f]. The
// transfer adds to the motion's own features the difference between that
// prediction for the asked style and for the motion's own style (the
// model's style means weighted by the probabilities it gives the motion:
// a motion already recognised as the style with p is still moved by the 1 - p
// it lacks), its own deviations kept, on each joint's rotation-vector mean
// and standard deviation:
//
//   r'(t) = r(t) + w(t) [ dm + (k - 1) (r(t) - m) ]      (per axis)
//
// r(t): the joint's rotation vector at frame t (the pelvis: its world
// rotation with the heading taken out, the others their local rotation, as
// the features read them); m, s: its mean and standard deviation over the
// motion; dm = strength x (mean offset); k = clamp((s + strength x sd
// offset) / s, min_sd_ratio, max_sd_ratio), 1 on an axis spreading less
// than 0.02 rad (noise); w(t): the key weight, 0 at every
// key frame, eased (smoothstep) to 1 over key_ease_s. Timing is not changed
// (the key poses are timed): the angular speeds follow the amplitude. A joint
// whose rotation vector may wrap (StyleTransferReport::kept_joints) is left
// as it is.
//
// Each mapped rotation is clamped to the skeleton's range of motion (the
// captured range: no knee bends backward) where the untransferred rotation
// is within it.
//
// Then the feet: where the untransferred motion has a leg's lowest foot
// joint origin below plant_height_m above the ground, its ankle is held
// where the untransferred motion has it (its world rotation turned by the
// transfer's change of the ankle's local rotation; the toes keep the
// transfer's) by two-bone inverse kinematics (foot_planting.hpp plant_leg's
// steps, the knee turned about its own hinge), blended in and out over
// plant_ease_s; the root moves down (or up) so that each held leg keeps the
// hip-ankle distance the transfer gave it (the knee bend of the style), the
// move smoothed over plant_ease_s and scaled by w(t). Key frames (w = 0) are
// left bit for bit as they were.
#include <cstddef>
#include <string>
#include <vector>

#include "mocap/common/motion/style.hpp"
#include "mocap/synth/synth.hpp"

namespace mocap {

struct StyleTransferParams {
  /// The asked style: one of the model's (InputError naming its styles
  /// otherwise).
  std::string style;
  /// Multiple of the style offset applied (finite, in [0, 4]; 1: the
  /// model's difference between the two styles; 0: no change).
  double strength = 1.0;
  /// Bounds of the per-axis spread ratio k (0 < min <= 1 <= max).
  double min_sd_ratio = 0.5, max_sd_ratio = 2.0;
  /// Seconds over which the weight eases from 0 at a key frame to 1 (> 0).
  double key_ease_s = 0.3;
  /// A leg is grounded at a frame where the untransferred motion has its
  /// lowest foot joint origin below this height above the ground, metres.
  double plant_height_m = 0.08;
  /// Seconds over which a grounded leg's hold eases in and out (> 0).
  double plant_ease_s = 0.1;
};

/// What the transfer did (the report's "style_transfer").
struct StyleTransferReport {
  /// The parameters it ran with (params.style: the style asked for).
  StyleTransferParams params;
  /// The style the untransferred motion is recognised as and its
  /// probability (the offset's origin weighs every style by its
  /// probability).
  std::string from_style;
  double from_p = 0.0;
  /// The content whose statistics the model predicts with, and whether it
  /// was recognised (false: the chosen partial motions' label).
  std::string content;
  bool content_recognised = false;
  /// The model's joints the transfer moved, and those it left as they
  /// were: a joint turning past 2.6 rad from its parent in a frame (the
  /// features' rotation vector wraps at half a turn) or whose mean rotation
  /// vector spreads over 0.8 rad on an axis over the content's clips.
  std::size_t joints = 0;
  std::vector<std::string> kept_joints;
  /// Frames whose weight is 0 (key frames): left as they were.
  std::size_t key_frames = 0;
  /// (leg, frame) pairs held where the untransferred motion has the foot.
  std::size_t held_foot_frames = 0;
  /// The largest move of the root (down or up), metres (>= 0).
  double max_root_drop_m = 0.0;
  /// Mean over the model's joints of the rotation-vector mean's change and
  /// of |k - 1| (radians; ratio), at weight 1.
  double mean_offset_rad = 0.0, mean_sd_change = 0.0;
};

/// The motion as the style features read it (Y up: the ground's normal).
StyleMotion synth_style_motion(const SynthSkeleton& sk, const std::vector<SynthFrame>& frames,
                               double frame_time_s);

/// Turns `frames` (changed in place) toward params.style, each mapped joint
/// rotation clamped to `range` where the untransferred one is within it
/// (none: not clamped; the held legs' inverse
/// kinematics is not clamped, so that the feet stay). `key_frames`: the
/// output frames that must not move (the query's key poses); `content`: a
/// content of the model to predict with (empty or unknown to the model: the
/// content discriminant's). Throws InputError("--style", ...) for a style
/// the model lacks (naming its styles) or bad parameters, and
/// InputError("--style-model", ...) for a motion the model cannot read
/// (fewer than 4 frames, a joint of the model the skeleton lacks: a model of
/// another rig). Deterministic and serial: the result does not depend on the
/// thread count.
StyleTransferReport transfer_style(const SynthSkeleton& sk, const RangeOfMotion* range,
                                   const StyleModel& model, const StyleTransferParams& params,
                                   const std::vector<std::size_t>& key_frames,
                                   const std::string& content, std::vector<SynthFrame>& frames,
                                   double frame_time_s);

}  // namespace mocap
