// Anthropometric table: de Leva's segment parameters and our shares for the
// joints the table has no row for (neck, clavicle, toes).
#include "body/anthropometry.hpp"

namespace mocap::detail {

namespace {

// de Leva (1996), Table 4, adjusted Zatsiorsky-Seluyanov
// values (docs/body-model.md reproduces them). Percentages of total mass and
// of segment length. `com` is measured from de Leva's origin point, which is
// the proximal joint for the limbs and the CRANIAL end for the head (vertex)
// and the trunk parts (suprasternale, xiphoid, omphalion); `com_from_top`
// marks the latter, whose bones in a capture skeleton point upwards.
struct DeLevaRow {
  double mass_pct;
  double com_pct;
  bool com_from_top;
  double r_sag_pct;    // about the antero-posterior (sagittal) axis
  double r_trans_pct;  // about the medio-lateral (transverse) axis
  double r_long_pct;   // about the long axis
};

struct DeLevaTable {
  DeLevaRow head, upper_trunk, middle_trunk, lower_trunk, upper_arm, forearm, hand, thigh, shank,
      foot;
};

constexpr DeLevaTable kDeLevaMale{
    {6.94, 59.76, true, 36.2, 37.6, 31.2},    // head (vertex - mid-gonion)
    {15.96, 29.99, true, 71.6, 45.4, 65.9},   // upper trunk (suprasternale - xiphoid)
    {16.33, 45.02, true, 48.2, 38.3, 46.8},   // middle trunk (xiphoid - omphalion)
    {11.17, 61.15, true, 61.5, 55.1, 58.7},   // lower trunk (omphalion - mid-hip)
    {2.71, 57.72, false, 28.5, 26.9, 15.8},   // upper arm
    {1.62, 45.74, false, 27.6, 26.5, 12.1},   // forearm
    {0.61, 79.00, false, 62.8, 51.3, 40.1},   // hand (wrist - 3rd metacarpale)
    {14.16, 40.95, false, 32.9, 32.9, 14.9},  // thigh
    {4.33, 44.59, false, 25.5, 24.9, 10.3},   // shank
    {1.37, 44.15, false, 25.7, 24.5, 12.4},   // foot (heel - toe tip)
};

constexpr DeLevaTable kDeLevaFemale{
    {6.68, 58.94, true, 33.0, 35.9, 31.8},    // head
    {15.45, 20.77, true, 74.6, 50.2, 71.8},   // upper trunk
    {14.65, 45.12, true, 43.3, 35.4, 41.5},   // middle trunk
    {12.47, 49.20, true, 43.3, 40.2, 44.4},   // lower trunk
    {2.55, 57.54, false, 27.8, 26.0, 14.8},   // upper arm
    {1.38, 45.59, false, 26.1, 25.7, 9.4},    // forearm
    {0.56, 74.74, false, 53.1, 45.4, 33.5},   // hand
    {14.78, 36.12, false, 36.9, 36.4, 16.2},  // thigh
    {4.81, 44.16, false, 27.1, 26.7, 9.3},    // shank
    {1.29, 40.14, false, 29.9, 27.9, 13.9},   // foot
};

// Shares of de Leva segments given to joints de Leva does not have (our
// modelling choice, docs/body-model.md): the neck takes a sixth of de Leva's
// head (which includes the neck), each clavicle a tenth of the upper trunk, each
// toes joint 15% of its foot. A share the skeleton cannot carry goes back.
constexpr double kNeckShareOfHead = 1.0 / 6.0;
constexpr double kClavicleShareOfUpperTrunk = 0.10;
constexpr double kToesShareOfFoot = 0.15;

ClassParams from_row(const DeLevaRow& r, double mass_fraction) {
  ClassParams p;
  p.mass_fraction = mass_fraction;
  p.com_fraction = r.com_from_top ? 1.0 - r.com_pct / 100.0 : r.com_pct / 100.0;
  p.r_sag = r.r_sag_pct / 100.0;
  p.r_trans = r.r_trans_pct / 100.0;
  p.r_long = r.r_long_pct / 100.0;
  return p;
}

}  // namespace

ClassParams class_params(SegmentClass c, Sex sex) {
  const DeLevaTable& t = sex == Sex::male ? kDeLevaMale : kDeLevaFemale;
  const double sum = t.head.mass_pct + t.upper_trunk.mass_pct + t.middle_trunk.mass_pct +
                     t.lower_trunk.mass_pct +
                     2.0 * (t.upper_arm.mass_pct + t.forearm.mass_pct + t.hand.mass_pct +
                            t.thigh.mass_pct + t.shank.mass_pct + t.foot.mass_pct);
  auto frac = [sum](double pct) { return pct / sum; };
  switch (c) {
    case SegmentClass::head:
      return from_row(t.head, frac(t.head.mass_pct) * (1.0 - kNeckShareOfHead));
    case SegmentClass::neck: {
      ClassParams p = from_row(t.head, frac(t.head.mass_pct) * kNeckShareOfHead);
      p.com_fraction = 0.5;
      return p;
    }
    case SegmentClass::upper_trunk:
      return from_row(t.upper_trunk,
                      frac(t.upper_trunk.mass_pct) * (1.0 - 2.0 * kClavicleShareOfUpperTrunk));
    case SegmentClass::middle_trunk:
      return from_row(t.middle_trunk, frac(t.middle_trunk.mass_pct));
    case SegmentClass::lower_trunk:
      return from_row(t.lower_trunk, frac(t.lower_trunk.mass_pct));
    case SegmentClass::clavicle: {
      ClassParams p =
          from_row(t.upper_arm, frac(t.upper_trunk.mass_pct) * kClavicleShareOfUpperTrunk);
      p.com_fraction = 0.5;
      return p;
    }
    case SegmentClass::upper_arm:
      return from_row(t.upper_arm, frac(t.upper_arm.mass_pct));
    case SegmentClass::forearm:
      return from_row(t.forearm, frac(t.forearm.mass_pct));
    case SegmentClass::hand:
      return from_row(t.hand, frac(t.hand.mass_pct));
    case SegmentClass::thigh:
      return from_row(t.thigh, frac(t.thigh.mass_pct));
    case SegmentClass::shank:
      return from_row(t.shank, frac(t.shank.mass_pct));
    case SegmentClass::foot:
      return from_row(t.foot, frac(t.foot.mass_pct) * (1.0 - kToesShareOfFoot));
    case SegmentClass::toes: {
      ClassParams p = from_row(t.foot, frac(t.foot.mass_pct) * kToesShareOfFoot);
      p.com_fraction = 0.5;
      return p;
    }
    case SegmentClass::none:
      break;
  }
  return ClassParams{};  // uniform rod, no mass
}

std::vector<SegmentClass> relatives(SegmentClass c) {
  using S = SegmentClass;
  switch (c) {
    case S::head:
      return {S::neck, S::upper_trunk, S::middle_trunk, S::lower_trunk};
    case S::neck:
      return {S::head, S::upper_trunk, S::middle_trunk, S::lower_trunk};
    case S::upper_trunk:
      return {S::middle_trunk, S::lower_trunk, S::neck, S::head};
    case S::middle_trunk:
      return {S::upper_trunk, S::lower_trunk};
    case S::lower_trunk:
      return {S::middle_trunk, S::upper_trunk};
    case S::clavicle:
      return {S::upper_trunk, S::middle_trunk, S::lower_trunk};
    case S::upper_arm:
      return {S::clavicle, S::upper_trunk, S::middle_trunk, S::lower_trunk};
    case S::forearm:
      return {S::upper_arm, S::clavicle, S::upper_trunk, S::middle_trunk};
    case S::hand:
      return {S::forearm, S::upper_arm, S::clavicle, S::upper_trunk};
    case S::thigh:
      return {S::lower_trunk, S::middle_trunk, S::upper_trunk};
    case S::shank:
      return {S::thigh, S::lower_trunk, S::middle_trunk};
    case S::foot:
      return {S::shank, S::thigh, S::lower_trunk};
    case S::toes:
      return {S::foot, S::shank, S::thigh, S::lower_trunk};
    case S::none:
      break;
  }
  return {};
}

}  // namespace mocap::detail
