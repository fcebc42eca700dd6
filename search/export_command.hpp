#pragma once
// mocap-search export: a partial motion of the index as BVH (docs/cli.md
// "mocap-search export"), chosen by clip and frames or by a line of search
// results. The motion is written by the writer synthesis uses
// (mocap/common/motion/export.hpp), so an exported piece and a synthesised
// motion are written alike.
#include <CLI/CLI.hpp>
#include <string>

namespace mocap {

struct ExportArgs {
  std::string index;
  std::string clip;
  std::string frames;
  std::string results;
  std::string id;
  std::string pair;  // read as text: a missing or bad number is a usage error (2)
  std::string rank;
  std::string out;
  bool force = false;
};

/// Adds the `export` subcommand to `app`; returns it.
CLI::App* add_export_command(CLI::App& app, ExportArgs& args);

/// Runs it: 0 when the file is written. Bad arguments or inputs throw
/// InputError naming the option or the file (and its line), before anything
/// is written.
int run_export(const ExportArgs& args);

}  // namespace mocap
