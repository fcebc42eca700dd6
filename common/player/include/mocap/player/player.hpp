#pragma once
// The 3D player of the HTML reports (docs/synthesis.md "3D player"): a
// self-contained <section data-figure="player"> that plays motions side by
// side in one WebGL view, built on three.js (its WebGLRenderer, BVHLoader and
// OrbitControls), with a timeline (query frames, transitions and partial
// motions marked), orbit / zoom, play / pause / scrub, a ground grid and the
// feet coloured in contact.
//
// The page needs no network: three.js and the player's own script are read
// from the player folder (player_dir()) when the page is written and inlined,
// gzip-compressed and base64-encoded, next to the motions (BVH text in the
// export layout, to_export_layout, which three.js's BVHLoader reads as we do)
// and their metadata (JSON). The browser inflates the modules with
// DecompressionStream and imports them from blob: URLs, so the page works
// from file:// in Chromium, Firefox and Safari (16.4 and later).
//
// Units in the metadata: metres, seconds; the BVH texts are in the file units
// of their skeleton (unit_m metres per unit).
//
// The library (mocap_player, common/player/) writes scenes and pages and
// knows motions on a clip's skeleton only; the scenes of a synthesis
// (mocap/synth/player_scene.hpp) and of search results
// (mocap/search/results_page.hpp) are built by the libraries that own them.
#include <cstddef>
#include <filesystem>
#include <string>
#include <vector>

#include <array>
#include <map>

#include "mocap/common/motion/clip_source.hpp"
#include "mocap/common/motion/skeleton_motion.hpp"

namespace mocap {

/// The player folder: $MOCAP_PLAYER_DIR when set and not empty, else the
/// folder the build knows (the source tree's common/player/web, a CMake
/// compile definition). It holds player.js, player.css and node_modules/three
/// (npm ci, run by scripts/setup, from common/player/web/package-lock.json).
std::filesystem::path player_dir();

/// The player's code, read from a player folder.
struct PlayerLibrary {
  std::filesystem::path dir;
  std::string three_version;   // node_modules/three/package.json "version"
  std::string three_core;      // build/three.core.js
  std::string three_module;    // build/three.module.js (imports ./three.core.js)
  std::string bvh_loader;      // examples/jsm/loaders/BVHLoader.js (imports three)
  std::string orbit_controls;  // examples/jsm/controls/OrbitControls.js (imports three)
  std::string app_js;          // player.js (imports three and the two add-ons)
  std::string app_css;         // player.css
};

/// Reads the player's files from `dir`. A missing or unreadable file throws
/// InputError(file, 0, "... (scripts/setup installs three.js there with npm
/// ci; MOCAP_PLAYER_DIR names another player folder)").
PlayerLibrary load_player_library(const std::filesystem::path& dir);

/// Per-frame foot state: '0' off the ground, '1' in contact (joint origin
/// below kSkatingHeightM = 5 cm above the ground, horizontal speed at most
/// kSkatingSpeedMps = 0.5 m/s), '2' skating (below 5 cm, faster): the rule
/// of the report's contact timeline (docs/synthesis.md "Measures"). The
/// speed of frame f is the horizontal displacement from f - 1 to f + 1 over
/// 2 dt (one-sided at the ends; 0 for a single frame).
inline constexpr char kFootAir = '0';
inline constexpr char kFootContact = '1';
inline constexpr char kFootSkating = '2';

/// One motion of the player.
struct PlayerMotion {
  std::string id;     // unique in its scene
  std::string tag;    // short, shown above the figure ("synthesised", "p1 r2")
  std::string label;  // in the legend
  /// Motions of one group share a row of the view (e.g. "synthesised",
  /// "pair 1"); "" with `attach`.
  std::string group;
  /// Drawn on the place of motion `attach` (same offset, translucent): the
  /// query frames on the synthesised motion. Empty: laid out in its group.
  std::string attach;
  std::string colour;  // CSS colour, e.g. "#c0392b"
  bool chosen = false;
  /// BVH text in the export layout (to_export_layout), file units.
  std::string bvh;
  double unit_m = 1.0;    // metres per BVH unit
  double ground_m = 0.0;  // ground height of the skeleton's model, metres
  double frame_time_s = 0.0;
  std::size_t frames = 0;
  /// The number shown for frame 0 (the clip's frame for a partial motion).
  std::size_t first_frame = 0;
  /// When frame 0 plays on the timeline, seconds; before it the motion holds
  /// frame 0, after its last frame it holds the last.
  double start_s = 0.0;
  /// Root (pelvis) path over the motion, metres: min x, max x, min z, max z.
  double box[4] = {0, 0, 0, 0};
  /// Joints not drawn (a static dummy root above the pelvis).
  std::vector<std::string> hidden_joints;
  /// Foot and toe joints and, per joint, one state character per frame.
  std::vector<std::string> foot_joints;
  std::vector<std::string> contacts;
};

/// A span of the timeline: kind "query" (a point: start_s = end_s),
/// "transition" or "partial".
struct PlayerMark {
  std::string kind;
  std::string label;
  double start_s = 0.0;
  double end_s = 0.0;
};

/// What one view plays: a synthesis, or one query's search results.
struct PlayerScene {
  std::string id;
  std::string title;
  double duration_s = 0.0;
  std::vector<PlayerMotion> motions;
  std::vector<PlayerMark> marks;
};

/// The motion `frames` (on skeleton `sk`, frame time `frame_time_s`) as a
/// player motion: BVH text (write_bvh of to_export_layout of
/// motion_raw_clip, 6 significant digits), root path box, hidden joints,
/// foot contacts. Label, group and timing are left to the caller.
PlayerMotion player_motion(const SynthSkeleton& sk, const std::vector<SynthFrame>& frames,
                           double frame_time_s);

/// Frames start..end (inclusive) of clip `clip` of `clips`, on the clip's
/// own skeleton, as a player motion (first_frame = start).
PlayerMotion player_clip_motion(const ClipSource& clips, std::size_t clip, std::size_t start,
                                std::size_t end);

/// Colours of the player's motions (CSS): a synthesised motion, a chosen (or
/// first-ranked) partial motion, completed query frames; other ranks take
/// player_rank_colour (a palette that avoids the feet's green and magenta).
inline constexpr const char* kPlayerSynthColour = "#c0392b";
inline constexpr const char* kPlayerChosenColour = "#b8860b";
inline constexpr const char* kPlayerQueryColour = "#1f5fbf";
const char* player_rank_colour(std::size_t rank);

/// When motion m's last frame plays, seconds (start_s for 0 or 1 frame).
double player_end_s(const PlayerMotion& m);

/// Player motions of clip frame ranges, each made once (player_clip_motion)
/// and copied for every further use of the same clip and frames.
class PlayerClipMotions {
 public:
  explicit PlayerClipMotions(const ClipSource& clips) : clips_(clips) {}
  PlayerMotion get(std::size_t clip, std::size_t start, std::size_t end);

 private:
  const ClipSource& clips_;
  std::map<std::array<std::size_t, 3>, PlayerMotion> made_;
};

/// The player section for `scenes` (one view; a menu chooses the scene when
/// there are several). Throws std::invalid_argument for no scene.
std::string player_html(const std::vector<PlayerScene>& scenes, const PlayerLibrary& library);

/// A whole page holding only the player (mocap-search --html, scripts/view).
std::string player_page(const std::string& title, const std::vector<PlayerScene>& scenes,
                        const PlayerLibrary& library);

}  // namespace mocap
