// mocap-search: queries against an index, and energy tools.
//
// Subcommands (docs/cli.md):
//   energy --from FILE:FRAME --to FILE:FRAME [--transition-time S] [--character C.json]
//          [--unit U] [--json]
// Exit status: 0 success; 2 usage error or nothing could be done (the message
// names the file or the argument). CLI11 parse errors use CLI11's own codes.
#include <fmt/format.h>
#include <CLI/CLI.hpp>

#include <exception>
#include <iostream>
#include <optional>
#include <string>

#include "mocap/energy_command.hpp"
#include "mocap/error.hpp"
#include "mocap/units.hpp"

#ifndef MOCAP_VERSION
#define MOCAP_VERSION "dev"
#endif

namespace {

constexpr int kExitOk = 0;
constexpr int kExitFatal = 2;

struct EnergyArgs {
  std::string from;
  std::string to;
  double transition_time_s = 0.5;
  std::string character;
  std::string unit = "auto";
  bool json = false;
};

void add_energy_command(CLI::App& app, EnergyArgs& args) {
  CLI::App* cmd = app.add_subcommand("energy",
                                     "Energy change of the transition between two capture frames: "
                                     "the approximate h (retrieval) and the full g "
                                     "(Newton-Euler with ground contact), in joules, with "
                                     "per-segment and per-joint terms (docs/energy.md).");
  cmd->add_option("--from", args.from,
                  "First state: FILE:FRAME (BVH file, 0-based frame; with its clip velocities)")
      ->required();
  cmd->add_option("--to", args.to, "Second state: FILE:FRAME (same skeleton as --from)")
      ->required();
  cmd->add_option("--transition-time", args.transition_time_s, "Transition time T in seconds (> 0)")
      ->default_val(0.5)
      ->check(CLI::PositiveNumber);
  cmd->add_option("--character", args.character,
                  "Character JSON file (docs/character.md); default body otherwise");
  cmd->add_option("--unit", args.unit,
                  "Length unit of both files: m, cm, mm, inch, cmu or auto (detected per file)")
      ->default_val("auto");
  cmd->add_flag("--json", args.json,
                "Print one JSON object: {h_J, g_J, terms: [{name, kind, h_J, g_J}], ...}");
}

int run_energy(const EnergyArgs& args) {
  mocap::EnergyCommandOptions o;
  o.from = mocap::parse_frame_spec(args.from, "--from");
  o.to = mocap::parse_frame_spec(args.to, "--to");
  o.transition_time_s = args.transition_time_s;
  o.character = args.character;
  if (args.unit != "auto") {
    o.unit = mocap::parse_unit(args.unit);
    if (!o.unit)
      throw mocap::InputError("--unit", 0,
                              "expected m, cm, mm, inch, cmu or auto, got '" + args.unit + "'");
  }
  const mocap::EnergyReport r = mocap::run_energy_command(o);
  std::cout << (args.json ? mocap::energy_report_json(r) + "\n" : mocap::energy_report_text(r));
  return kExitOk;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"mocap-search: retrieval of partial motions by energy change, and energy tools"};
  app.set_version_flag("--version", MOCAP_VERSION);
  app.require_subcommand(1);
  EnergyArgs energy;
  add_energy_command(app, energy);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  }
  try {
    if (app.got_subcommand("energy")) return run_energy(energy);
  } catch (const mocap::InputError& e) {
    fmt::print(stderr, "mocap-search: {}\n", e.what());
    return kExitFatal;
  } catch (const std::exception& e) {
    fmt::print(stderr, "mocap-search: error: {}\n", e.what());
    return kExitFatal;
  }
  return kExitFatal;
}
