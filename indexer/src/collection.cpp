#include "mocap/indexer/collection.hpp"

#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <fstream>
#include <set>
#include <system_error>

#include "mocap/indexer/asf_pairing.hpp"

namespace mocap {

namespace fs = std::filesystem;

namespace {
bool has_bvh_extension(const fs::path& p) {
  std::string ext = p.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return ext == ".bvh";
}

// A clip file: .bvh or .amc (an .asf is a skeleton, read with its takes).
bool is_clip_file_name(const fs::path& p) {
  return has_bvh_extension(p) || has_amc_extension(p);
}

// Every .bvh and .amc file under `dir`, following links to folders but entering each
// folder once (by its canonical path: a link loop or a second link to a
// folder adds nothing). Hidden entries are skipped; unreadable folders and
// clip entries that are not regular files (FIFOs, dangling links) are
// reported in out.problems.
void add_folder(const fs::path& dir, Collection& out, std::set<fs::path>& visited) {
  std::error_code ec;
  const fs::path top = fs::canonical(dir, ec);
  if (!ec && !visited.insert(top).second) return;
  fs::recursive_directory_iterator it(dir,
                                      fs::directory_options::follow_directory_symlink |
                                          fs::directory_options::skip_permission_denied,
                                      ec);
  if (ec) {
    out.problems.push_back({dir.string(), ec.message()});
    return;
  }
  for (const fs::recursive_directory_iterator end; it != end; it.increment(ec)) {
    if (ec) {
      out.problems.push_back({dir.string(), ec.message()});
      break;
    }
    const fs::path& p = it->path();
    const std::string name = p.filename().string();
    const bool is_dir = it->is_directory(ec);
    if (!name.empty() && name[0] == '.') {
      if (is_dir) it.disable_recursion_pending();
      continue;
    }
    if (is_dir) {
      std::error_code cec;
      const fs::path real = fs::canonical(p, cec);
      if (cec || !visited.insert(real).second) {
        it.disable_recursion_pending();  // entered already (a link loop or a second link)
        continue;
      }
      if (::access(p.c_str(), R_OK | X_OK) != 0)
        out.problems.push_back({p.string(), "folder not readable: skipped"});
      continue;
    }
    if (!is_clip_file_name(p)) continue;
    if (it->is_regular_file(ec))
      out.files.push_back({p});
    else
      out.problems.push_back({p.string(),
                              "not a regular file (a FIFO, a device or a dangling "
                              "link): skipped"});
  }
}

void add_list_file(const fs::path& list, Collection& out, std::set<fs::path>& visited) {
  std::ifstream in(list);
  if (!in) {
    out.problems.push_back({list.string(), "cannot open list file"});
    return;
  }
  std::string line;
  while (std::getline(in, line)) {
    const auto first = line.find_first_not_of(" \t\r");
    if (first == std::string::npos || line[first] == '#') continue;
    const auto last = line.find_last_not_of(" \t\r");
    fs::path p = line.substr(first, last - first + 1);
    if (p.is_relative()) p = list.parent_path() / p;
    std::error_code ec;
    if (fs::is_directory(p, ec))
      add_folder(p, out, visited);
    else if (fs::is_regular_file(p, ec)) {
      if (!has_asf_extension(p)) out.files.push_back({p});
    } else
      out.problems.push_back(
          {p.string(), "no such file or directory (listed in " + list.string() + ")"});
  }
}
}  // namespace

Collection list_collection(const std::vector<std::string>& inputs) {
  Collection out;
  std::set<fs::path> visited;  // canonical folders entered
  for (const std::string& input : inputs) {
    const fs::path p(input);
    std::error_code ec;
    if (fs::is_directory(p, ec))
      add_folder(p, out, visited);
    else if (fs::is_regular_file(p, ec)) {
      if (is_clip_file_name(p))
        out.files.push_back({p});
      else if (!has_asf_extension(p))
        add_list_file(p, out, visited);
    } else
      out.problems.push_back({input, "no such file or directory"});
  }
  std::sort(out.files.begin(), out.files.end(),
            [](const CollectionEntry& a, const CollectionEntry& b) { return a.path < b.path; });
  out.files.erase(std::unique(out.files.begin(), out.files.end(),
                              [](const CollectionEntry& a, const CollectionEntry& b) {
                                return a.path == b.path;
                              }),
                  out.files.end());
  return out;
}

}  // namespace mocap
