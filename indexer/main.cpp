// mocap-index: capture collections -> HDF5 index, and tools to look at files.
//
// Subcommands (docs/cli.md):
//   inspect FILE --frame N [--unit U] [--character C.json] [--json]
//   summary INPUT... [--unit U] [--json]
// Exit status: 0 success; 1 some inputs were bad (reported, the rest done);
// 2 usage error or nothing could be done.
#include <CLI/CLI.hpp>
#include <fmt/format.h>

#include <cstdio>
#include <filesystem>
#include <iostream>

#include "mocap/collection.hpp"
#include "mocap/error.hpp"
#include "mocap/inspect.hpp"
#include "mocap/units.hpp"

namespace {

constexpr int kExitOk = 0;
constexpr int kExitSomeFailed = 1;
constexpr int kExitFatal = 2;

std::optional<mocap::LengthUnit> unit_option(const std::string& s) {
  if (s.empty() || s == "auto") return std::nullopt;
  auto u = mocap::parse_unit(s);
  if (!u) throw CLI::ValidationError("--unit", "expected m, cm, mm, inch, cmu or auto, got '" + s + "'");
  return u;
}

int run_inspect(const std::string& file, std::size_t frame, const std::string& unit,
                const std::string& character, bool json) {
  mocap::InspectOptions opt;
  opt.file = file;
  opt.frame = frame;
  opt.unit = unit_option(unit);
  if (!character.empty()) opt.character = character;
  const nlohmann::json out = mocap::inspect_frame(opt);
  if (json) {
    std::cout << out.dump() << '\n';
    return kExitOk;
  }
  fmt::print("{}  frame {} of {}  ({:.4f} s/frame, unit {} = {} m, body {:.1f} kg)\n",
             out["file"].get<std::string>(), frame, out["frames"].get<std::size_t>(),
             out["frame_time_s"].get<double>(), out["unit"].get<std::string>(),
             out["unit_scale_m"].get<double>(), out["total_mass_kg"].get<double>());
  fmt::print("{:<4} {:<20} {:>6}  {:>9} {:>9} {:>9}\n", "#", "joint", "parent", "x_m", "y_m", "z_m");
  int i = 0;
  for (const auto& j : out["joints"]) {
    const auto& p = j["position_m"];
    fmt::print("{:<4} {:<20} {:>6}  {:>9.4f} {:>9.4f} {:>9.4f}\n", i++, j["name"].get<std::string>(),
               j["parent"].get<int>(), p[0].get<double>(), p[1].get<double>(), p[2].get<double>());
  }
  fmt::print("\n{:<20} {:<13} {:<6} {:>8}\n", "segment", "class", "side", "mass_kg");
  for (const auto& s : out["segments"])
    fmt::print("{:<20} {:<13} {:<6} {:>8.3f}\n", s["joint"].get<std::string>(),
               s["class"].get<std::string>(), s["side"].get<std::string>(),
               s["mass_kg"].get<double>());
  return kExitOk;
}

int run_summary(const std::vector<std::string>& inputs, const std::string& unit, bool json) {
  const mocap::Collection col = mocap::list_collection(inputs);
  for (const auto& p : col.problems) fmt::print(stderr, "mocap-index: {}: {}\n", p.input, p.reason);
  if (col.files.empty()) {
    fmt::print(stderr, "mocap-index: no BVH files found in the inputs\n");
    return kExitFatal;
  }
  std::vector<std::filesystem::path> files;
  files.reserve(col.files.size());
  for (const auto& e : col.files) files.push_back(e.path);
  const auto sums = mocap::summarize_files(files, unit_option(unit));

  std::size_t ok = 0, frames = 0, bytes = 0;
  double seconds = 0.0;
  for (const auto& s : sums) {
    if (!s.ok) continue;
    ++ok;
    frames += s.frames;
    bytes += s.bytes;
    seconds += static_cast<double>(s.frames) * s.frame_time_s;
  }
  const std::size_t failed = sums.size() - ok + col.problems.size();
  if (json) {
    nlohmann::json clips = nlohmann::json::array();
    for (const auto& s : sums) clips.push_back(mocap::to_json(s));
    nlohmann::json problems = nlohmann::json::array();
    for (const auto& p : col.problems) problems.push_back({{"input", p.input}, {"error", p.reason}});
    std::cout << nlohmann::json{{"clips", std::move(clips)},
                                {"input_problems", std::move(problems)},
                                {"total",
                                 {{"clips", sums.size()},
                                  {"ok", ok},
                                  {"failed", failed},
                                  {"frames", frames},
                                  {"duration_s", seconds},
                                  {"bytes", bytes}}}}
                     .dump()
              << '\n';
  } else {
    fmt::print("{:<48} {:>7} {:>5} {:>8} {:>6} {:>5} {:>8}\n", "clip", "frames", "fps", "sec",
               "joints", "unit", "height_m");
    for (const auto& s : sums) {
      const std::string name = std::filesystem::path(s.file).filename().string();
      if (!s.ok) {
        fmt::print("{:<48} ERROR {}\n", name, s.error);
        continue;
      }
      fmt::print("{:<48} {:>7} {:>5.0f} {:>8.2f} {:>6} {:>5} {:>8.3f}\n", name, s.frames,
                 1.0 / s.frame_time_s, static_cast<double>(s.frames) * s.frame_time_s, s.joints,
                 s.unit, s.height_m);
    }
    fmt::print("\n{} clips ({} ok, {} failed), {} frames, {:.1f} s of motion, {:.1f} MB\n",
               sums.size(), ok, failed, frames, seconds, static_cast<double>(bytes) / 1e6);
  }
  return failed ? kExitSomeFailed : kExitOk;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"mocap-index: turn motion-capture collections into an index, and inspect BVH files"};
  app.require_subcommand(1);
  app.set_version_flag("--version", std::string(MOCAP_VERSION));

  std::string file, unit, character;
  std::size_t frame = 0;
  bool json = false;
  auto* inspect = app.add_subcommand(
      "inspect", "World-space joints and body segments of one frame of a BVH file (metres, Y up)");
  inspect->add_option("FILE", file, "BVH file")->required();
  inspect->add_option("--frame", frame, "Frame number, 0-based")->required();
  inspect->add_option("--unit", unit,
                      "Length unit of the file: m, cm, mm, inch, cmu (0.056444 m) or auto "
                      "(default: detected from the standing height)");
  inspect->add_option("--character", character, "Character JSON (docs/character.md); default 70 kg male");
  inspect->add_flag("--json", json, "Print one JSON object (docs/cli.md)");

  std::vector<std::string> inputs;
  std::string sum_unit;
  bool sum_json = false;
  auto* summary = app.add_subcommand(
      "summary", "Parse capture files and print one line per clip (frames, rate, unit, height)");
  summary->add_option("INPUT", inputs, "Folders (searched recursively), .bvh files or list files")
      ->required();
  summary->add_option("--unit", sum_unit, "Length unit of the files (default: detected per file)");
  summary->add_flag("--json", sum_json, "Print one JSON object");

  CLI11_PARSE(app, argc, argv);
  try {
    if (*inspect) return run_inspect(file, frame, unit, character, json);
    if (*summary) return run_summary(inputs, sum_unit, sum_json);
  } catch (const CLI::ValidationError& e) {
    fmt::print(stderr, "mocap-index: error: {}\n", e.what());
    return kExitFatal;
  } catch (const mocap::InputError& e) {
    fmt::print(stderr, "mocap-index: error: {}\n", e.what());
    return kExitFatal;
  } catch (const std::exception& e) {
    fmt::print(stderr, "mocap-index: internal error: {}\n", e.what());
    return kExitFatal;
  }
  return kExitFatal;
}
