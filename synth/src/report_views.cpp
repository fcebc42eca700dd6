// The drawings of REPORT.html (report_views.hpp).
#include "report_views.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "measures.hpp"
#include "report_notes.hpp"

namespace mocap::synth_detail {

std::string fixed(int digits, double v) {
  char b[64];
  std::snprintf(b, sizeof b, "%.*f", digits, v);
  return b;
}

namespace {

// One stick figure in a cell of width w and height h (2 m tall), centred on
// its root: front view x = world x, side view x = world z; y up.
void stick_figure(std::ostringstream& o, const SynthSkeleton& sk, const SynthFrame& f, double x0,
                  double w, double h, const char* colour, View view) {
  WorldPose wp;
  synth_world_pose(sk, f, wp);
  const Eigen::Vector3d root = f.root_position_m;
  const double scale = h / 2.0;
  const int axis = view == View::front ? 0 : 2;
  auto px = [&](const Eigen::Vector3d& p) {
    return std::pair<double, double>{x0 + w / 2 + (p[axis] - root[axis]) * scale,
                                     h - 4 - p.y() * scale};
  };
  for (std::size_t j = 0; j < sk.joint_count(); ++j) {
    const int p = sk.skeleton.parents[j];
    if (p < 0 || (sk.is_root_chain[static_cast<std::size_t>(p)] && p != sk.root_joint)) continue;
    const auto a = px(wp.positions_m[static_cast<std::size_t>(p)]);
    const auto b = px(wp.positions_m[j]);
    o << "<line x1=\"" << fixed(1, a.first) << "\" y1=\"" << fixed(1, a.second) << "\" x2=\""
      << fixed(1, b.first) << "\" y2=\"" << fixed(1, b.second) << "\" stroke=\"" << colour
      << "\" stroke-width=\"2.5\" stroke-linecap=\"round\"/>";
  }
}

// The kind of segment output frame f belongs to ("query", "partial", "transition").
std::string kind_of(const SynthResult& r, std::size_t f) {
  for (const MotionSegment& s : r.segments)
    if (f >= s.first_frame && f < s.first_frame + s.frame_count) return s.kind;
  return "";
}

const char* kind_colour(const std::string& kind) {
  if (kind == "transition") return "#e67e22";
  if (kind == "query") return "#1f5fbf";
  return "#c0392b";
}

// Ticks at 1, 2 or 5 times a power of ten, about `count` over [0, max].
double tick_step(double max, int count) {
  const double raw = std::max(max, 1e-9) / count;
  const double p = std::pow(10.0, std::floor(std::log10(raw)));
  for (double m : {1.0, 2.0, 5.0, 10.0})
    if (m * p >= raw) return m * p;
  return 10.0 * p;
}

}  // namespace

void filmstrip(std::ostringstream& o, const std::string& id, const std::string& title,
               const SynthSkeleton& sk, const std::vector<SynthFrame>& frames,
               std::size_t max_figures, const char* colour, View view, std::size_t first_frame) {
  const std::size_t n = frames.size();
  const std::size_t k = std::min(n, max_figures);
  const double w = 70, h = 150, label = 14;
  o << "<figure data-figure=\"" << id << "\"><figcaption>" << html_escape(title)
    << (view == View::front ? " (front: x across)" : " (side: z across)") << "</figcaption>";
  o << "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" << w * static_cast<double>(k)
    << "\" height=\"" << h + label << "\"><rect width=\"100%\" height=\"100%\" fill=\"#f7f7f2\"/>"
    << "<line x1=\"0\" y1=\"" << h - 4 << "\" x2=\"" << w * static_cast<double>(k) << "\" y2=\""
    << h - 4 << "\" stroke=\"#999\"/>";
  for (std::size_t i = 0; i < k; ++i) {
    const std::size_t f = k <= 1 ? 0 : i * (n - 1) / (k - 1);
    stick_figure(o, sk, frames[f], w * static_cast<double>(i), w, h, colour, view);
    o << "<text x=\"" << fixed(1, w * (static_cast<double>(i) + 0.5)) << "\" y=\"" << h + label - 3
      << "\" font-size=\"11\" text-anchor=\"middle\" fill=\"#444\">" << first_frame + f
      << "</text>";
  }
  o << "</svg></figure>\n";
}

void top_view(std::ostringstream& o, const SynthResult& r) {
  const SynthSkeleton& sk = *r.skeleton;
  const auto& fr = r.frames;
  if (fr.empty()) return;
  double x0 = fr[0].root_position_m.x(), x1 = x0, z0 = fr[0].root_position_m.z(), z1 = z0;
  for (const SynthFrame& f : fr) {
    x0 = std::min(x0, f.root_position_m.x());
    x1 = std::max(x1, f.root_position_m.x());
    z0 = std::min(z0, f.root_position_m.z());
    z1 = std::max(z1, f.root_position_m.z());
  }
  const double pad = 0.5;  // metres around the path
  x0 -= pad, x1 += pad, z0 -= pad, z1 += pad;
  const double W = 520, H = 520, margin = 30;
  const double scale = std::min((W - 2 * margin) / (x1 - x0), (H - 2 * margin) / (z1 - z0));
  auto sx = [&](double x) { return margin + (x - x0) * scale; };
  auto sy = [&](double z) { return margin + (z - z0) * scale; };
  o << "<figure data-figure=\"top-view\"><figcaption>Root path from above (x to the right, z "
       "down the page; grid 1 m; arrows: facing direction every 10 frames; blue dots: query "
       "frames; orange: transitions)</figcaption><svg xmlns=\"http://www.w3.org/2000/svg\" "
       "width=\""
    << W << "\" height=\"" << H << "\"><rect width=\"100%\" height=\"100%\" fill=\"#fbfbfb\"/>";
  for (double x = std::ceil(x0); x <= x1; x += 1.0)
    o << "<line x1=\"" << fixed(1, sx(x)) << "\" y1=\"" << fixed(1, sy(z0)) << "\" x2=\""
      << fixed(1, sx(x)) << "\" y2=\"" << fixed(1, sy(z1)) << "\" stroke=\"#e2e2e2\"/><text x=\""
      << fixed(1, sx(x) + 2) << "\" y=\"" << fixed(1, margin - 4)
      << "\" font-size=\"10\" fill=\"#777\">x " << fixed(0, x) << "</text>";
  for (double z = std::ceil(z0); z <= z1; z += 1.0)
    o << "<line x1=\"" << fixed(1, sx(x0)) << "\" y1=\"" << fixed(1, sy(z)) << "\" x2=\""
      << fixed(1, sx(x1)) << "\" y2=\"" << fixed(1, sy(z))
      << "\" stroke=\"#e2e2e2\"/><text x=\"2\" "
      << "y=\"" << fixed(1, sy(z) - 2) << "\" font-size=\"10\" fill=\"#777\">z " << fixed(0, z)
      << "</text>";
  for (std::size_t f = 1; f < fr.size(); ++f)
    o << "<line x1=\"" << fixed(1, sx(fr[f - 1].root_position_m.x())) << "\" y1=\""
      << fixed(1, sy(fr[f - 1].root_position_m.z())) << "\" x2=\""
      << fixed(1, sx(fr[f].root_position_m.x())) << "\" y2=\""
      << fixed(1, sy(fr[f].root_position_m.z())) << "\" stroke=\"" << kind_colour(kind_of(r, f))
      << "\" stroke-width=\"3\"/>";
  for (std::size_t f = 0; f < fr.size(); f += 10) {
    const double a = root_heading(sk, fr[f]);  // heading 0 faces +z
    const double bx = fr[f].root_position_m.x(), bz = fr[f].root_position_m.z();
    o << "<line x1=\"" << fixed(1, sx(bx)) << "\" y1=\"" << fixed(1, sy(bz)) << "\" x2=\""
      << fixed(1, sx(bx + 0.3 * std::sin(a))) << "\" y2=\"" << fixed(1, sy(bz + 0.3 * std::cos(a)))
      << "\" stroke=\"#333\" stroke-width=\"1.5\"/><circle cx=\""
      << fixed(1, sx(bx + 0.3 * std::sin(a))) << "\" cy=\"" << fixed(1, sy(bz + 0.3 * std::cos(a)))
      << "\" r=\"2.5\" fill=\"#333\"/>";
  }
  for (const MotionSegment& s : r.segments)
    if (s.kind == "query" && s.frame_count > 0) {
      const Eigen::Vector3d& p = fr[s.first_frame].root_position_m;
      o << "<circle cx=\"" << fixed(1, sx(p.x())) << "\" cy=\"" << fixed(1, sy(p.z()))
        << "\" r=\"6\" fill=\"#1f5fbf\"/><text x=\"" << fixed(1, sx(p.x()) + 8) << "\" y=\""
        << fixed(1, sy(p.z()) + 4) << "\" font-size=\"12\" fill=\"#1f5fbf\">Q" << s.pair
        << "</text>";
    }
  o << "</svg></figure>\n";
}

void energy_plot(std::ostringstream& o, const SynthResult& r) {
  const auto& e = r.step_energies_J;
  const double W = 1100, H = 240, left = 60, bottom = 30, top = 10, right = 10;
  double emax = 1e-9;
  for (double v : e) emax = std::max(emax, v);
  const double ystep = tick_step(emax, 5);
  const double ymax = std::ceil(emax / ystep) * ystep;
  const double nsteps = std::max<double>(1.0, static_cast<double>(e.size()));
  auto sx = [&](double step) { return left + (W - left - right) * step / nsteps; };
  auto sy = [&](double v) { return H - bottom - (H - bottom - top) * v / ymax; };
  o << "<figure data-figure=\"energy\"><figcaption>Full energy change g per step along the "
       "motion (J per step; max "
    << fixed(1, emax)
    << " J); shaded: transitions</figcaption><svg xmlns=\"http://www.w3.org/2000/svg\" width=\""
    << W << "\" height=\"" << H << "\"><rect width=\"100%\" height=\"100%\" fill=\"#fbfbfb\"/>";
  for (const MotionSegment& s : r.segments)
    if (s.kind == "transition" && s.frame_count > 0)
      o << "<rect x=\"" << fixed(1, sx(static_cast<double>(s.first_frame))) << "\" y=\"" << top
        << "\" width=\"" << fixed(1, sx(static_cast<double>(s.frame_count)) - left)
        << "\" height=\"" << H - bottom - top << "\" fill=\"#ffe0d0\"/>";
  for (double v = 0.0; v <= ymax + 1e-9; v += ystep)
    o << "<line x1=\"" << left << "\" y1=\"" << fixed(1, sy(v)) << "\" x2=\"" << W - right
      << "\" y2=\"" << fixed(1, sy(v)) << "\" stroke=\"#e4e4e4\"/><text x=\"" << left - 4
      << "\" y=\"" << fixed(1, sy(v) + 4) << "\" font-size=\"11\" text-anchor=\"end\">"
      << fixed(ystep < 1 ? 1 : 0, v) << "</text>";
  const double xstep = tick_step(nsteps, 10);
  for (double f = 0.0; f <= nsteps + 1e-9; f += xstep)
    o << "<line x1=\"" << fixed(1, sx(f)) << "\" y1=\"" << H - bottom << "\" x2=\""
      << fixed(1, sx(f)) << "\" y2=\"" << H - bottom + 4 << "\" stroke=\"#555\"/><text x=\""
      << fixed(1, sx(f)) << "\" y=\"" << H - bottom + 16
      << "\" font-size=\"11\" text-anchor=\"middle\">" << fixed(0, f) << "</text>";
  o << "<line x1=\"" << left << "\" y1=\"" << top << "\" x2=\"" << left << "\" y2=\"" << H - bottom
    << "\" stroke=\"#555\"/><line x1=\"" << left << "\" y1=\"" << H - bottom << "\" x2=\""
    << W - right << "\" y2=\"" << H - bottom << "\" stroke=\"#555\"/>"
    << "<text x=\"14\" y=\"" << fixed(1, (H - bottom) / 2)
    << "\" font-size=\"12\" transform=\"rotate(-90 14 " << fixed(1, (H - bottom) / 2)
    << ")\" text-anchor=\"middle\">g (J)</text><text x=\"" << fixed(1, (W + left) / 2) << "\" y=\""
    << H - 2 << "\" font-size=\"12\" text-anchor=\"middle\">output frame</text>";
  o << "<polyline fill=\"none\" stroke=\"#c0392b\" stroke-width=\"2\" points=\"";
  for (std::size_t i = 0; i < e.size(); ++i)
    o << fixed(1, sx(static_cast<double>(i) + 0.5)) << "," << fixed(1, sy(e[i])) << " ";
  o << "\"/></svg></figure>\n";
}

namespace {

// One row of the contact timeline: its label, and a cell per frame coloured
// by the energy model's contact state (FootContactRow::states).
void contact_row(std::ostringstream& o, const std::string& label, const std::string& states,
                 const std::string& note, double y, double left, double cw, double row_h) {
  o << "<text x=\"" << left - 6 << "\" y=\"" << fixed(1, y + row_h - 4)
    << "\" font-size=\"11\" text-anchor=\"end\">" << html_escape(label) << "</text>";
  if (!note.empty())
    o << "<text x=\"" << left + 4 << "\" y=\"" << fixed(1, y + row_h - 4)
      << "\" font-size=\"11\" fill=\"#777\" data-note=\"never-in-reach\">" << html_escape(note)
      << "</text>";
  for (std::size_t f = 0; f < states.size(); ++f) {
    if (states[f] == '.') continue;
    o << "<rect x=\"" << fixed(2, left + cw * static_cast<double>(f)) << "\" y=\""
      << fixed(1, y + 2) << "\" width=\"" << fixed(2, cw) << "\" height=\"" << row_h - 4
      << "\" fill=\"" << (states[f] == 'c' ? "#2ca02c" : "#ff9f1c") << "\" data-state=\""
      << states[f] << "\"/>";
  }
}

// The skating row: a red mark on each step (between frames f - 1 and f) in
// which a foot joint skates (measures.hpp step_skating).
void skating_row(std::ostringstream& o, const SynthResult& r, double y, double left, double cw,
                 double row_h) {
  const SynthSkeleton& sk = *r.skeleton;
  o << "<text x=\"" << left - 6 << "\" y=\"" << fixed(1, y + row_h - 4)
    << "\" font-size=\"11\" text-anchor=\"end\">skating</text>";
  WorldPose a, b;
  synth_world_pose(sk, r.frames[0], a);
  for (std::size_t f = 1; f < r.frames.size(); ++f) {
    synth_world_pose(sk, r.frames[f], b);
    if (step_skating(sk, a, b, r.frame_time_s).joints > 0)
      o << "<rect x=\"" << fixed(2, left + cw * (static_cast<double>(f) - 0.5)) << "\" y=\""
        << fixed(1, y + 2) << "\" width=\"" << fixed(2, cw) << "\" height=\"" << row_h - 4
        << "\" fill=\"#d62728\" data-state=\"skating\"/>";
    std::swap(a, b);
  }
}

}  // namespace

void contact_timeline(std::ostringstream& o, const SynthResult& r) {
  const std::vector<FootContactRow> rows = foot_contact_rows(*r.skeleton, r.frames, r.frame_time_s);
  if (rows.empty()) return;
  const EnergyParams& ep = r.skeleton->model.params;
  const double W = 1100, row_h = 16, left = 110, top = 4;
  const double H = top + row_h * static_cast<double>(rows.size() + 1) + 22;
  const double cw = (W - left - 10) / static_cast<double>(r.frames.size());
  o << "<figure data-figure=\"contacts\"><figcaption>Foot contact per frame as the energy "
       "model sees it: green in contact (the segment's contact point, its joint origin for the "
       "foot (the ankle) and its joint or bone tip for the toes, within "
    << fixed(0, 100 * ep.contact_height_m) << " cm of the ground and slower than "
    << fixed(1, ep.contact_speed_mps) << " m/s), orange within "
    << fixed(0, 100 * ep.contact_height_m)
    << " cm but faster (sliding: no support), blank higher; last row, red: the steps that "
       "skate (a foot joint below "
    << fixed(0, 100 * kSkatingHeightM) << " cm moving faster than " << fixed(1, kSkatingSpeedMps)
    << " m/s); shaded: transitions</figcaption><svg xmlns=\"http://www.w3.org/2000/svg\" "
       "width=\""
    << W << "\" height=\"" << H << "\"><rect width=\"100%\" height=\"100%\" fill=\"#fbfbfb\"/>";
  for (const MotionSegment& s : r.segments)
    if (s.kind == "transition" && s.frame_count > 0)
      o << "<rect x=\"" << fixed(1, left + cw * static_cast<double>(s.first_frame)) << "\" y=\"0\" "
        << "width=\"" << fixed(1, cw * static_cast<double>(s.frame_count)) << "\" height=\""
        << H - 20 << "\" fill=\"#ffe0d0\"/>";
  for (std::size_t i = 0; i < rows.size(); ++i)
    contact_row(o, rows[i].name, rows[i].states, never_in_reach_note(ep, rows[i]),
                top + row_h * static_cast<double>(i), left, cw, row_h);
  skating_row(o, r, top + row_h * static_cast<double>(rows.size()), left, cw, row_h);
  o << "<text x=\"" << left << "\" y=\"" << H - 6 << "\" font-size=\"11\">frame 0</text><text x=\""
    << W - 10 << "\" y=\"" << H - 6 << "\" font-size=\"11\" text-anchor=\"end\">frame "
    << r.frames.size() - 1 << "</text></svg></figure>\n";
}

}  // namespace mocap::synth_detail
