// The files of a batch synthesis in one folder (synth_batch_folder.hpp).
#include "mocap/synth/synth_batch_folder.hpp"

#include <chrono>
#include <iostream>
#include <nlohmann/json.hpp>
#include <system_error>

#include "mocap/common/util/atomic_file.hpp"
#include "mocap/common/util/output_path.hpp"
#include "mocap/player/player.hpp"

namespace mocap {

namespace {
// The file extension of each MotionFormat, in its order.
constexpr const char* kMotionExtensions[] = {".bvh", ".glb", ".npz"};
}  // namespace
namespace {

bool name_byte(char c) {
  return (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '.' ||
         c == '_' || c == '-';
}

std::string json_line(const nlohmann::ordered_json& j) {
  return j.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
}

// DIR as a folder: created (with its parents) when missing; InputError
// ("--out-dir") when it is something else or cannot be made.
void make_folder(const std::filesystem::path& dir) {
  std::error_code ec;
  const auto status = std::filesystem::status(dir, ec);
  if (std::filesystem::exists(status)) {
    if (!std::filesystem::is_directory(status))
      throw InputError("--out-dir", 0, dir.string() + " exists and is not a folder");
    return;
  }
  std::filesystem::create_directories(dir, ec);
  if (ec || !std::filesystem::is_directory(dir))
    throw InputError(
        "--out-dir", 0,
        "cannot create the folder " + dir.string() + ": " + (ec ? ec.message() : "not a folder"));
}

}  // namespace

std::string synth_batch_file_name(const std::string& id, std::size_t line) {
  std::string name = id;
  for (char& c : name)
    if (!name_byte(c)) c = '_';
  if (name.empty() || name == "." || name == "..") return "query-" + std::to_string(line);
  return name;
}

SynthBatchFolder::SynthBatchFolder(const ClipSource& clips, const SynthOptions& options,
                                   SynthBatchFolderOptions folder)
    : clips_(clips), options_(options), folder_(std::move(folder)) {
  make_folder(folder_.dir);
  const std::filesystem::path summary =
      folder_.summary.empty() ? folder_.dir / "summary.jsonl" : folder_.summary;
  check_outputs_and_inputs({{"--summary", summary}}, folder_.inputs);
  summary_ = checked_output_path(summary, OutputKind::jsonl, folder_.force, "--summary");
  if (!folder_.html_reports) return;
  try {
    player_ = std::make_unique<PlayerLibrary>(load_player_library(player_dir()));
  } catch (const InputError& e) {
    player_missing_ = e.what();
    std::cerr << "mocap-synth: warning: the reports have no 3D player: " << player_missing_ << "\n";
  }
}

SynthBatchFolder::~SynthBatchFolder() = default;

// The policy on one query's outputs: none is the summary or an input, each
// may be replaced (InputError("--out-dir", ...) otherwise).
void SynthBatchFolder::check_query_files(QueryFiles& f) const {
  std::vector<std::pair<std::string, std::filesystem::path>> outputs = {{"--out-dir", f.bvh},
                                                                        {"--summary", summary_}};
  if (folder_.reports) outputs.emplace_back("--out-dir", f.report);
  if (folder_.html_reports) outputs.emplace_back("--out-dir", f.html);
  check_outputs_and_inputs(outputs, folder_.inputs);
  f.bvh_out =
      checked_output_path(f.bvh, motion_output_kind(folder_.format), folder_.force, "--out-dir");
  if (folder_.reports)
    f.report_out = checked_output_path(f.report, OutputKind::json, folder_.force, "--out-dir");
  if (folder_.html_reports)
    f.html_out = checked_output_path(f.html, OutputKind::html, folder_.force, "--out-dir");
}

void SynthBatchFolder::name(std::vector<SynthBatchQuery>& queries) {
  files_.assign(queries.size(), QueryFiles{});
  lines_.assign(queries.size(), std::string());
  errors_.assign(queries.size(), std::nullopt);
  std::unordered_map<std::string, std::size_t> taken;  // name -> the query that has it
  for (std::size_t i = 0; i < queries.size(); ++i) {
    SynthBatchQuery& q = queries[i];
    if (q.error) continue;
    const std::string name = synth_batch_file_name(q.id, q.line);
    const auto [at, fresh] = taken.emplace(name, i);
    if (!fresh) {
      const SynthBatchQuery& first = queries[at->second];
      q.error = InputError("--out-dir", 0,
                           "query \"" + q.id + "\" would write " + name +
                               ".*, the name of query \"" + first.id + "\" (line " +
                               std::to_string(first.line) + "): give them distinct ids");
      continue;
    }
    QueryFiles& f = files_[i];
    f.bvh = folder_.dir / (name + kMotionExtensions[static_cast<int>(folder_.format)]);
    f.report = folder_.dir / (name + ".json");
    f.html = folder_.dir / (name + ".html");
    try {
      check_query_files(f);
    } catch (const InputError& e) {
      q.error = e;
    }
  }
}

// The summary line of a query made (synth_batch_folder.hpp).
std::string SynthBatchFolder::made_line(const SynthBatchDone& done, const QueryFiles& files,
                                        double time_ms) const {
  const SynthResult& r = done.motion->result;
  nlohmann::ordered_json j;
  j["id"] = done.query->id;
  j["line"] = done.query->line;
  if (folder_.format == MotionFormat::bvh) j["bvh"] = files.bvh.string();
  j["motion"] = files.bvh.string();
  if (folder_.reports) j["report"] = files.report.string();
  if (folder_.html_reports) j["html"] = files.html.string();
  j["frames"] = r.frames.size();
  j["duration_s"] =
      r.frames.empty() ? 0.0 : static_cast<double>(r.frames.size() - 1) * r.frame_time_s;
  nlohmann::ordered_json m = nlohmann::ordered_json::object();
  if (r.whole_measures) {
    m["w_J"] = r.whole_measures->work_energy_J;
    m["unsupported_J"] = r.whole_measures->unsupported_J;
    m["no_contact_ratio"] = r.whole_measures->no_contact_ratio;
    m["peak_angular_speed_radps"] = r.whole_measures->peak_angular_speed_radps;
  }
  m["foot_skating_ratio"] = r.motion_measures.skating_ratio;
  j["measures"] = std::move(m);
  j["time_ms"] = time_ms;
  return json_line(j);
}

void SynthBatchFolder::write(const SynthBatchDone& done) {
  const auto t0 = std::chrono::steady_clock::now();
  const SynthBatchQuery& q = *done.query;
  std::optional<InputError> error = done.error;
  std::string line;
  if (!error) try {
      const QueryFiles& f = files_.at(done.index);
      const SynthResult& r = done.motion->result;
      write_motion_file(r, f.bvh_out);
      const double ms =
          done.synth_ms +
          std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
      if (folder_.reports)
        write_file_atomically(f.report_out, synth_report_json(clips_, *q.query, folder_.batch_path,
                                                              q.ranked, r, options_, q.search_ms,
                                                              q.search_ms + ms, f.bvh.string()));
      if (folder_.html_reports)
        write_file_atomically(f.html_out, synth_report_html(clips_, *q.query, q.ranked, r, options_,
                                                            player_.get(), player_missing_));
      line = made_line(done, f,
                       done.synth_ms + std::chrono::duration<double, std::milli>(
                                           std::chrono::steady_clock::now() - t0)
                                           .count());
    } catch (const InputError& e) {
      error = e;
    }
  if (error) {
    nlohmann::ordered_json j;
    j["id"] = q.id;
    j["line"] = q.line;
    j["error"] = error->what();
    line = json_line(j);
  }
  const std::lock_guard<std::mutex> lock(mutex_);
  lines_.at(done.index) = std::move(line);
  errors_.at(done.index) = std::move(error);
}

void SynthBatchFolder::finish() {
  std::string text;
  for (const std::string& line : lines_) text += line + "\n";
  write_file_atomically(summary_, text);
}

}  // namespace mocap
