// BVH writer: a RawClip as BVH text (every joint's channels as they are) and
// written to a file through a temporary file and a rename.
#include <algorithm>
#include <charconv>
#include <cmath>
#include <fstream>
#include <random>
#include <stdexcept>
#include <system_error>

#include "io/bvh_text.hpp"
#include "mocap/common/io/bvh.hpp"
#include "mocap/common/util/error.hpp"

namespace mocap {

namespace detail {

// Checks the invariants the writer relies on (a hand-built clip may break them).
void check_clip(const RawClip& clip) {
  // The clip's shape is the calling code's: a broken one is a logic error.
  const auto misuse = [&clip](const std::string& what) {
    throw std::invalid_argument("write_bvh: " + clip.source + ": " + what);
  };
  const std::size_t n = clip.joints.size();
  if (n == 0) misuse("clip has no joints: expected at least one ROOT");
  for (std::size_t j = 0; j < n; ++j) {
    const RawJoint& rj = clip.joints[j];
    if (rj.parent >= static_cast<int>(j) || rj.parent < -1)
      misuse("joint '" + rj.name + "' must come after its parent");
    if (rj.name.empty() || rj.name.find_first_of("\r\n{}") != std::string::npos ||
        is_blank(rj.name.front()) || is_blank(rj.name.back()) ||
        std::any_of(rj.name.begin(), rj.name.end(), is_binary))
      throw InputError(clip.source, 0, "joint name " + show(rj.name) + " cannot be written to BVH");
    if (rj.first_column + rj.channels.size() > clip.channel_count)
      misuse("joint '" + rj.name + "' has channels past the frame row");
    if (rj.channels.size() > 6) misuse("joint '" + rj.name + "' has more than 6 channels");
  }
  if (clip.values.size() != clip.frame_count * clip.channel_count)
    misuse("values size does not match frame_count x channel_count");
  if (!(clip.frame_time_s > 0.0) || !std::isfinite(clip.frame_time_s))
    throw InputError(clip.source, 0, "frame time must be a positive number of seconds");
}

}  // namespace detail

namespace {

class Writer {
 public:
  explicit Writer(int precision) : precision_(std::clamp(precision, 1, 17)) {}

  void text(std::string_view s) { out_.append(s); }
  void ch(char c) { out_.push_back(c); }
  void tabs(std::size_t n) { out_.append(n, '\t'); }
  // printf("%.*g") form: at most `precision` significant digits, trailing zeros
  // dropped, so numbers that need fewer digits come out in their short form.
  void number(double v) {
    char buf[64];
    const auto r = std::to_chars(buf, buf + sizeof buf, v, std::chars_format::general, precision_);
    out_.append(buf, static_cast<std::size_t>(r.ptr - buf));
  }
  void exact(double v) {
    char buf[64];
    const auto r = std::to_chars(buf, buf + sizeof buf, v);
    out_.append(buf, static_cast<std::size_t>(r.ptr - buf));
  }
  std::string& str() { return out_; }

 private:
  int precision_;
  std::string out_;
};

}  // namespace

std::string write_bvh(const RawClip& clip, int precision) {
  detail::check_clip(clip);
  const std::size_t n = clip.joints.size();
  std::vector<std::vector<std::size_t>> children(n);
  for (std::size_t j = 0; j < n; ++j)
    if (clip.joints[j].parent >= 0)
      children[static_cast<std::size_t>(clip.joints[j].parent)].push_back(j);

  Writer w(precision);
  w.str().reserve(clip.values.size() * 10 + n * 128 + 64);
  const auto write_offset = [&w](std::size_t depth, const Eigen::Vector3d& offset) {
    w.tabs(depth);
    w.text("OFFSET");
    for (int a = 0; a < 3; ++a) {
      w.ch(' ');
      w.number(offset[a]);
    }
    w.ch('\n');
  };
  w.text("HIERARCHY\n");
  // Depth-first over the tree; the order in which joints are written is the
  // column order of the written frame rows.
  std::vector<std::size_t> order;
  order.reserve(n);
  struct Item {
    std::size_t joint;
    std::size_t next_child;
  };
  std::vector<Item> stack;
  for (std::size_t r = 0; r < n; ++r) {
    if (clip.joints[r].parent >= 0) continue;
    stack.push_back({r, 0});
    bool entering = true;
    while (!stack.empty()) {
      Item& it = stack.back();
      const RawJoint& j = clip.joints[it.joint];
      const std::size_t depth = stack.size() - 1;
      if (entering) {
        order.push_back(it.joint);
        w.tabs(depth);
        w.text(j.parent < 0 ? "ROOT " : "JOINT ");
        w.text(j.name);
        w.ch('\n');
        w.tabs(depth);
        w.text("{\n");
        write_offset(depth + 1, j.offset);
        // Always a CHANNELS line, "CHANNELS 0" for a joint without: Blender's
        // importer (and others) expect one in every joint.
        {
          w.tabs(depth + 1);
          w.text("CHANNELS ");
          w.text(std::to_string(j.channels.size()));
          for (Channel c : j.channels) {
            w.ch(' ');
            w.text(channel_name(c));
          }
          w.ch('\n');
        }
      }
      const std::vector<std::size_t>& kids = children[it.joint];
      if (it.next_child < kids.size()) {
        const std::size_t child = kids[it.next_child++];
        stack.push_back({child, 0});
        entering = true;
        continue;
      }
      if (j.has_end_site) {
        w.tabs(depth + 1);
        w.text("End Site\n");
        w.tabs(depth + 1);
        w.text("{\n");
        write_offset(depth + 2, j.end_site);
        w.tabs(depth + 1);
        w.text("}\n");
      }
      w.tabs(depth);
      w.text("}\n");
      stack.pop_back();
      entering = false;
    }
  }
  w.text("MOTION\nFrames: ");
  w.text(std::to_string(clip.frame_count));
  w.text("\nFrame Time: ");
  w.exact(clip.frame_time_s);
  w.ch('\n');
  for (std::size_t f = 0; f < clip.frame_count; ++f) {
    const double* row = clip.frame(f);
    bool first = true;
    for (std::size_t j : order) {
      const RawJoint& rj = clip.joints[j];
      for (std::size_t c = 0; c < rj.channels.size(); ++c) {
        const double v = row[rj.first_column + c];
        if (!std::isfinite(v))
          throw InputError(
              clip.source, 0,
              "non-finite value at frame " + std::to_string(f) + ", joint '" + rj.name + "'");
        if (!first) w.ch(' ');
        first = false;
        w.number(v);
      }
    }
    w.ch('\n');
  }
  return std::move(w.str());
}

void write_bvh_file(const RawClip& clip, const std::filesystem::path& path, int precision) {
  const std::string text = write_bvh(clip, precision);
  std::random_device rd;
  std::filesystem::path tmp = path;
  tmp += ".tmp-" + std::to_string(rd());
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    if (!out)
      throw InputError(path.string(), 0, "cannot open a temporary file next to it for writing");
    out.write(text.data(), static_cast<std::streamsize>(text.size()));
    out.flush();
    if (!out) {
      out.close();
      std::error_code ec;
      std::filesystem::remove(tmp, ec);
      throw InputError(path.string(), 0, "cannot write file (disk full?)");
    }
  }
  std::error_code ec;
  std::filesystem::rename(tmp, path, ec);
  if (ec) {
    std::error_code ec2;
    std::filesystem::remove(tmp, ec2);
    throw InputError(path.string(), 0, "cannot rename temporary file into place: " + ec.message());
  }
}

}  // namespace mocap
