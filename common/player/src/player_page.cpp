// The player's page (player.hpp): the library read from the player folder,
// inlined gzip-compressed and base64-encoded, the scenes as JSON.
#include "mocap/player/player.hpp"

#include <zlib.h>

#include <cstdlib>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <stdexcept>

#include "mocap/common/util/error.hpp"
#include "mocap/common/util/html_text.hpp"
#include "mocap/common/util/json_text.hpp"

#ifndef MOCAP_PLAYER_DIR
#define MOCAP_PLAYER_DIR "common/player/web"
#endif

namespace mocap {
namespace {

std::string read_player_file(const std::filesystem::path& dir, const std::string& name) {
  const std::filesystem::path path = dir / name;
  std::ifstream in(path, std::ios::binary);
  std::ostringstream text;
  if (in) text << in.rdbuf();
  if (!in || text.str().empty())
    throw InputError(path.string(), 0,
                     "missing or unreadable: the 3D player needs it (scripts/setup installs "
                     "three.js there with npm ci; MOCAP_PLAYER_DIR names another player folder)");
  return text.str();
}

// RFC 1952 gzip of `text` (zlib, level 9).
std::string gzip(const std::string& text) {
  z_stream z{};
  if (deflateInit2(&z, 9, Z_DEFLATED, 15 + 16, 9, Z_DEFAULT_STRATEGY) != Z_OK)
    throw std::runtime_error("gzip: deflateInit2 failed");
  std::string out(deflateBound(&z, static_cast<uLong>(text.size())), '\0');
  z.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(text.data()));
  z.avail_in = static_cast<uInt>(text.size());
  z.next_out = reinterpret_cast<Bytef*>(out.data());
  z.avail_out = static_cast<uInt>(out.size());
  const int rc = deflate(&z, Z_FINISH);
  out.resize(z.total_out);
  deflateEnd(&z);
  if (rc != Z_STREAM_END) throw std::runtime_error("gzip: deflate failed");
  return out;
}

std::string base64(const std::string& bytes) {
  static const char* abc = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  out.reserve((bytes.size() + 2) / 3 * 4);
  std::size_t i = 0;
  for (; i + 2 < bytes.size(); i += 3) {
    const auto a = static_cast<unsigned char>(bytes[i]),
               b = static_cast<unsigned char>(bytes[i + 1]),
               c = static_cast<unsigned char>(bytes[i + 2]);
    out += abc[a >> 2];
    out += abc[((a & 3) << 4) | (b >> 4)];
    out += abc[((b & 15) << 2) | (c >> 6)];
    out += abc[c & 63];
  }
  if (i < bytes.size()) {
    const auto a = static_cast<unsigned char>(bytes[i]);
    const unsigned b = i + 1 < bytes.size() ? static_cast<unsigned char>(bytes[i + 1]) : 0u;
    out += abc[a >> 2];
    out += abc[((a & 3) << 4) | (b >> 4)];
    out += i + 1 < bytes.size() ? abc[(b & 15) << 2] : '=';
    out += '=';
  }
  return out;
}

// JSON text that can stand inside a <script> element: '<' only occurs in
// strings, written as \u003c.
std::string script_json(const nlohmann::json& j) {
  const std::string text = json_text(j);
  std::string out;
  out.reserve(text.size());
  for (char c : text)
    if (c == '<')
      out += "\\u003c";
    else
      out += c;
  return out;
}

nlohmann::json scene_json(const PlayerScene& s) {
  nlohmann::json motions = nlohmann::json::array();
  for (const PlayerMotion& m : s.motions)
    motions.push_back({{"id", m.id},
                       {"tag", m.tag},
                       {"label", m.label},
                       {"group", m.group},
                       {"attach", m.attach},
                       {"colour", m.colour},
                       {"chosen", m.chosen},
                       {"unit_m", m.unit_m},
                       {"ground_m", m.ground_m},
                       {"frame_time_s", m.frame_time_s},
                       {"frames", m.frames},
                       {"first_frame", m.first_frame},
                       {"start_s", m.start_s},
                       {"box_m", {m.box[0], m.box[1], m.box[2], m.box[3]}},
                       {"hidden_joints", m.hidden_joints},
                       {"foot_joints", m.foot_joints},
                       {"contacts", m.contacts},
                       {"bvh", m.bvh}});
  nlohmann::json marks = nlohmann::json::array();
  for (const PlayerMark& k : s.marks)
    marks.push_back(
        {{"kind", k.kind}, {"label", k.label}, {"start_s", k.start_s}, {"end_s", k.end_s}});
  return {{"id", s.id},
          {"title", s.title},
          {"duration_s", s.duration_s},
          {"motions", motions},
          {"marks", marks}};
}

// The classic script that inflates the modules, imports them from blob:
// URLs (each module's imports rewritten to its dependencies' URLs) and
// starts the player; a failure is shown in the section and recorded in
// data-player-state="error" and data-player-error.
constexpr const char* kLoader = R"JS(
(async () => {
  const root = document.getElementById('mocap-player');
  const fail = (e) => {
    const msg = String(e && e.message ? e.message : e);
    root.dataset.playerState = 'error';
    root.dataset.playerError = msg;
    const p = root.querySelector('.mp-status');
    if (p) p.textContent = 'The 3D player could not start: ' + msg;
  };
  try {
    if (typeof DecompressionStream === 'undefined')
      throw new Error('this browser has no DecompressionStream (Chromium 80, Firefox 113, Safari 16.4 or later)');
    const inflate = async (id) => {
      const bin = Uint8Array.from(atob(document.getElementById(id).textContent.trim()), (c) => c.charCodeAt(0));
      const stream = new Blob([bin]).stream().pipeThrough(new DecompressionStream('gzip'));
      return await new Response(stream).text();
    };
    const url = (text) => URL.createObjectURL(new Blob([text], { type: 'text/javascript' }));
    const swap = (text, from, to) => {
      const out = text.split(from).join(JSON.stringify(to));
      if (out === text) throw new Error('no import of ' + from + ' to rewrite');
      return out;
    };
    const core = url(await inflate('mp-three-core'));
    const three = url(swap(await inflate('mp-three-module'), "'./three.core.js'", core));
    const bvh = url(swap(await inflate('mp-bvh-loader'), "'three'", three));
    const orbit = url(swap(await inflate('mp-orbit-controls'), "'three'", three));
    let app = await inflate('mp-app');
    app = swap(app, "'three/addons/loaders/BVHLoader.js'", bvh);
    app = swap(app, "'three/addons/controls/OrbitControls.js'", orbit);
    app = swap(app, "'three'", three);
    const player = await import(url(app));
    await player.start(root, JSON.parse(document.getElementById('mp-data').textContent));
  } catch (e) {
    fail(e);
  }
})();
)JS";

void module_script(std::ostringstream& o, const char* id, const std::string& text) {
  o << "<script type=\"application/octet-stream\" data-encoding=\"gzip+base64\" id=\"" << id
    << "\">" << base64(gzip(text)) << "</script>\n";
}

}  // namespace

std::filesystem::path player_dir() {
  const char* env = std::getenv("MOCAP_PLAYER_DIR");
  return std::filesystem::path(env && *env ? env : MOCAP_PLAYER_DIR);
}

PlayerLibrary load_player_library(const std::filesystem::path& dir) {
  PlayerLibrary lib;
  lib.dir = dir;
  const std::filesystem::path three = "node_modules/three";
  const std::string package = read_player_file(dir, (three / "package.json").string());
  try {
    lib.three_version = nlohmann::json::parse(package).at("version").get<std::string>();
  } catch (const nlohmann::json::exception& e) {
    throw InputError((dir / three / "package.json").string(), 0,
                     std::string("no version: ") + e.what());
  }
  lib.three_core = read_player_file(dir, (three / "build/three.core.js").string());
  lib.three_module = read_player_file(dir, (three / "build/three.module.js").string());
  lib.bvh_loader = read_player_file(dir, (three / "examples/jsm/loaders/BVHLoader.js").string());
  lib.orbit_controls =
      read_player_file(dir, (three / "examples/jsm/controls/OrbitControls.js").string());
  lib.app_js = read_player_file(dir, "player.js");
  lib.app_css = read_player_file(dir, "player.css");
  return lib;
}

std::string player_html(const std::vector<PlayerScene>& scenes, const PlayerLibrary& library) {
  if (scenes.empty()) throw std::invalid_argument("player_html: no scene");
  nlohmann::json scenes_json = nlohmann::json::array();
  for (const PlayerScene& s : scenes) scenes_json.push_back(scene_json(s));
  const nlohmann::json data = {{"three_version", library.three_version}, {"scenes", scenes_json}};
  std::ostringstream o;
  o << "<section id=\"mocap-player\" class=\"mocap-player\" data-figure=\"player\" "
       "data-player-state=\"loading\"><style>"
    << library.app_css << "</style>\n<h2>3D player</h2><p class=\"mp-status\">Loading the 3D "
    << "player (three.js " << html_escape(library.three_version)
    << ")&hellip;</p><noscript><p>The 3D player needs JavaScript.</p></noscript>\n";
  o << "<script type=\"application/json\" id=\"mp-data\">" << script_json(data) << "</script>\n";
  module_script(o, "mp-three-core", library.three_core);
  module_script(o, "mp-three-module", library.three_module);
  module_script(o, "mp-bvh-loader", library.bvh_loader);
  module_script(o, "mp-orbit-controls", library.orbit_controls);
  module_script(o, "mp-app", library.app_js);
  o << "<script>" << kLoader << "</script></section>\n";
  return o.str();
}

std::string player_page(const std::string& title, const std::vector<PlayerScene>& scenes,
                        const PlayerLibrary& library) {
  std::ostringstream o;
  o << "<!DOCTYPE html><html lang=\"en\"><head><meta charset=\"utf-8\"><title>"
    << html_escape(title)
    << "</title><style>body{font-family:sans-serif;margin:24px;background:#fff;color:#222}"
       "</style></head><body data-report=\"mocap-player\">\n<h1>"
    << html_escape(title) << "</h1>\n"
    << player_html(scenes, library) << "</body></html>\n";
  return o.str();
}

}  // namespace mocap
