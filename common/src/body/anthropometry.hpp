#pragma once
// Anthropometric parameters per segment class (internal to the body model).
//
// de Leva (1996), Table 4 (adjusted Zatsiorsky-Seluyanov values, male and
// female; docs/body-model.md reproduces them), put into our joint convention,
// plus the shares given to the joints de Leva has no row for (neck, clavicle,
// toes) and where a class's mass goes when a skeleton lacks that class.
#include <vector>

#include "mocap/common/body/character.hpp"

namespace mocap::detail {

// Radii of a uniform thin rod (fractions of length): transverse sqrt(1/12).
constexpr double kRodTransverse = 0.28867513459481287;

/// Per-class parameters in our joint convention: mass as a fraction of the
/// total mass (table normalised to sum to 1), COM as a fraction of the bone
/// from the joint origin, radii as fractions of the bone length.
struct ClassParams {
  double mass_fraction = 0.0;
  double com_fraction = 0.5;
  double r_sag = kRodTransverse;
  double r_trans = kRodTransverse;
  double r_long = 0.0;
};

/// Parameters of one class (per side for sided classes), sex-specific. The
/// mass fractions of the 13 massive classes (sided ones counted twice) sum to
/// 1; none gets a massless uniform rod.
ClassParams class_params(SegmentClass c, Sex sex);

/// Where a class's mass goes when the skeleton has no joint of that class
/// (same side for sided relatives), in order of preference. Empty for none.
std::vector<SegmentClass> relatives(SegmentClass c);

}  // namespace mocap::detail
