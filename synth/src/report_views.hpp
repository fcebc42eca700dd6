// The drawings of REPORT.html (private to synth/src): filmstrips from the
// front and the side with frame numbers, the root path from above, the
// energy curve with axes and the foot-contact timeline. Each figure is an
// inline SVG in a <figure data-figure="ID"> (the report tests look for the
// ids). Units on the page: metres, joules, frames.
#pragma once

#include <sstream>
#include <string>
#include <vector>

#include "mocap/common/util/html_text.hpp"
#include "mocap/synth/synth.hpp"
#include "mocap/synth/synth_job.hpp"

namespace mocap::synth_detail {

/// Fixed-point text with `digits` decimals.
std::string fixed(int digits, double v);

/// Which way a filmstrip looks: from the front (screen right = world +x) or
/// from the side (screen right = world +z). Each figure is centred on its
/// own root; the top view shows where the root goes.
enum class View { front, side };

/// `max_figures` evenly spaced frames of `frames` as stick figures, each
/// labelled with its frame number (first_frame + index).
void filmstrip(std::ostringstream& o, const std::string& id, const std::string& title,
               const SynthSkeleton& sk, const std::vector<SynthFrame>& frames,
               std::size_t max_figures, const char* colour, View view = View::front,
               std::size_t first_frame = 0);

/// The root path from above (x right, z down the page), scaled to fit, with
/// a metre grid, its segments coloured by kind (partial motion, transition),
/// the query frames marked, and the facing direction every 10 frames.
void top_view(std::ostringstream& o, const SynthResult& result);

/// g per step with labelled axes (frame, J) and the transitions shaded.
void energy_plot(std::ostringstream& o, const SynthResult& result);

/// Per foot segment (SynthSkeleton::foot_joints), per frame, the energy
/// model's contact (measures.hpp foot_contact_rows): in contact, within
/// contact height but too fast, or higher; and a row of the steps that
/// skate (measures.hpp step_skating); transitions shaded. Nothing for fewer
/// than two frames.
void contact_timeline(std::ostringstream& o, const SynthResult& result);

}  // namespace mocap::synth_detail
