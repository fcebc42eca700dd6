// BVH reader: the tokenizer over the whole text, the hierarchy parser, the
// motion (frame) parser with its window, and the public read functions.
#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstring>
#include <optional>
#include <stdexcept>
#include <system_error>
#include <unordered_map>
#include <utility>

#include "io/bvh_text.hpp"
#include "mocap/common/io/bvh.hpp"
#include "mocap/common/util/error.hpp"
#include "mocap/common/util/file.hpp"
#include "mocap/common/util/input_limits.hpp"

namespace mocap {

namespace {

// Ranges a BVH file's numbers must lie in (docs/cli.md "Value ranges"): finite values
// beyond them are not motion capture, and would make the dynamics overflow
// or lose all precision (an angle of 1e308 degrees).
constexpr double kMaxBvhValue = 1e7;
constexpr double kMinFrameTime = 1e-5, kMaxFrameTime = 60.0;

using detail::after_blanks;
using detail::is_binary;
using detail::is_blank;
using detail::is_space;
using detail::parse_double;
using detail::show;

std::optional<Channel> channel_from_name(std::string_view s) {
  if (s.size() != 9) return std::nullopt;
  constexpr Channel kChannels[] = {Channel::Xposition, Channel::Yposition, Channel::Zposition,
                                   Channel::Xrotation, Channel::Yrotation, Channel::Zrotation};
  for (Channel c : kChannels)
    if (s == channel_name(c)) return c;
  return std::nullopt;
}

class BvhParser {
 public:
  BvhParser(std::string_view text, const std::string& source)
      : begin_(text.data()), p_(text.data()), end_(text.data() + text.size()), source_(source) {}

  // Only frames [first, first + count) are read (parse_bvh_window): the frame
  // lines before them are skipped to their newline unread, those after them
  // are not looked at.
  void set_window(std::size_t first, std::size_t count) {
    window_ = true;
    first_ = first;
    count_ = count;
  }
  std::size_t declared_frames() const { return declared_; }

  RawClip parse() {
    RawClip clip = parse_head();
    parse_motion(clip);
    return clip;
  }

  // Through the MOTION keyword: the joints and channel_count. The parser then
  // stands right after MOTION (head_bytes() into the text, on line line()).
  RawClip parse_head() {
    RawClip clip;
    clip.source = source_;
    // UTF-8 byte order mark.
    if (end_ - p_ >= 3 && std::memcmp(p_, "\xEF\xBB\xBF", 3) == 0) p_ += 3;
    skip_space();
    if (p_ == end_) fail(line_, "empty file: expected HIERARCHY");
    const std::string_view first = token();
    if (first != "HIERARCHY") fail(token_line_, "expected HIERARCHY, found " + show(first));
    parse_hierarchy(clip);
    return clip;
  }
  std::size_t head_bytes() const { return static_cast<std::size_t>(p_ - begin_); }
  std::size_t line() const { return line_; }

  // The motion section of a text whose first `known.prefix.size()` bytes are
  // known's hierarchy (known.heads(text)): as parse() from there on.
  RawClip parse_after(const BvhHierarchy& known) {
    RawClip clip = known.clip;
    clip.source = source_;
    p_ = begin_ + known.prefix.size();
    line_ = known.motion_line;
    parse_motion(clip);
    return clip;
  }

 private:
  [[noreturn]] void fail(std::size_t line, const std::string& message) const {
    throw InputError(source_, line, message);
  }

  void skip_space() {
    while (p_ < end_) {
      const char c = *p_;
      if (c == '\n') {
        ++line_;
      } else if (!is_blank(c)) {
        return;
      }
      ++p_;
    }
  }

  void skip_blanks() { p_ = after_blanks(p_, end_); }

  // Moves p_ to the first byte at which `stop` holds (or the end of the text)
  // and returns where it started; a binary byte on the way throws.
  template <class Stop>
  const char* scan_text_until(Stop stop) {
    const char* start = p_;
    while (p_ < end_ && !stop(*p_)) {
      if (is_binary(*p_))
        fail(line_, "binary data (byte " + show(std::string_view(p_, 1)) + "): expected BVH text");
      ++p_;
    }
    return start;
  }

  // Next whitespace-separated token (empty at the end of the text); its line is token_line_.
  std::string_view token() {
    skip_space();
    token_line_ = line_;
    return rest_token_on_line();
  }

  // Rest of the current line without surrounding blanks (joint names may hold spaces).
  std::string_view rest_of_line() {
    skip_blanks();
    const char* start = scan_text_until([](char c) { return c == '\n'; });
    const char* stop = p_;
    while (stop > start && is_blank(stop[-1])) --stop;
    return {start, static_cast<std::size_t>(stop - start)};
  }

  void expect(std::string_view want, const char* what) {
    const std::string_view tok = token();
    if (tok != want)
      fail(token_line_, std::string("expected ") + what + ", found " +
                            (tok.empty() ? std::string("end of file") : show(tok)));
  }

  double number(const char* what) {
    const std::string_view tok = token();
    if (tok.empty()) fail(token_line_, std::string("truncated file: expected ") + what);
    double v = 0.0;
    const char* stop = parse_double(tok.data(), tok.data() + tok.size(), v);
    if (stop != tok.data() + tok.size())
      fail(token_line_, std::string("expected a number (") + what + "), found " + show(tok));
    if (!std::isfinite(v))
      fail(token_line_, std::string("expected a finite number (") + what + ")");
    if (std::abs(v) > kMaxBvhValue)
      fail(token_line_, std::string("value out of range (") + what + "): " + show(tok) +
                            "; |value| must be at most 1e7 (file units or degrees)");
    return v;
  }

  Eigen::Vector3d offset_values() {
    Eigen::Vector3d v;
    for (int a = 0; a < 3; ++a) v[a] = number("OFFSET value");
    return v;
  }

  // Joint name after ROOT/JOINT; "ROOT Hips {" on one line also opens the block.
  std::string joint_name(const char* keyword, bool& opened) {
    const std::size_t line = line_;
    std::string_view name = rest_of_line();
    opened = false;
    if (!name.empty() && name.back() == '{') {
      name.remove_suffix(1);
      while (!name.empty() && is_blank(name.back())) name.remove_suffix(1);
      opened = true;
    }
    if (name.empty()) fail(line, std::string("expected a joint name after ") + keyword);
    if (name.find_first_of("{}\r") != std::string_view::npos)
      fail(line, "expected a joint name without braces or carriage returns, found " + show(name));
    return std::string(name);
  }

  // The rest of an "End Site" line: an optional name that several exporters
  // write ("End Site Head_end", read by Blender; it names nothing we keep) and
  // the opening brace, on that line or the next.
  void end_site_name_and_brace() {
    const std::size_t line = line_;
    std::string_view rest = rest_of_line();
    bool opened = false;
    if (!rest.empty() && rest.back() == '{') {
      rest.remove_suffix(1);
      opened = true;
    }
    if (rest.find_first_of("{}") != std::string_view::npos)
      fail(line, "expected an End Site name without braces, found " + show(rest));
    if (!opened) expect("{", "'{' after End Site");
  }

  // A ROOT or JOINT after its keyword: its name and opening brace (`brace`
  // says what is expected when the brace is missing); the joint, a child of
  // `parent` (-1 for a ROOT) whose channels start at `column`, is appended to
  // `clip`. Returns its index.
  int add_joint(RawClip& clip, const char* keyword, const char* brace, int parent,
                std::size_t column) {
    bool opened = false;
    RawJoint j;
    const std::size_t line = token_line_;
    // Real rigs have tens to a few hundred joints.
    if (const std::size_t most = input_limits().bvh_joints; clip.joints.size() >= most)
      fail(line, "more than " + std::to_string(most) +
                     " joints: not a character skeleton (docs/cli.md \"Input limits\", "
                     "--max-joints)");
    j.name = joint_name(keyword, opened);
    const auto [seen, fresh] = joint_lines_.emplace(j.name, line);
    if (!fresh)
      fail(line, "joint name " + show(j.name) + " defined twice (first on line " +
                     std::to_string(seen->second) + "): joints are found by name");
    j.parent = parent;
    j.first_column = column;
    if (!opened) expect("{", brace);
    clip.joints.push_back(std::move(j));
    return static_cast<int>(clip.joints.size() - 1);
  }

  void parse_channels(RawJoint& joint) {
    const std::size_t line = token_line_;
    skip_blanks();
    const std::string_view count_tok = rest_token_on_line();
    if (count_tok.empty()) fail(line, "expected the channel count after CHANNELS");
    unsigned count = 0;
    const auto [ptr, ec] =
        std::from_chars(count_tok.data(), count_tok.data() + count_tok.size(), count);
    if (ec != std::errc() || ptr != count_tok.data() + count_tok.size() || count > 6)
      fail(line, "expected a channel count 0..6 after CHANNELS, found " + show(count_tok));
    std::size_t listed = 0;
    joint.channels.reserve(count);  // one allocation per joint (query frames parse headers often)
    for (;;) {
      skip_blanks();
      const std::string_view name = rest_token_on_line();
      if (name.empty()) break;
      ++listed;
      const std::optional<Channel> c = channel_from_name(name);
      if (!c)
        fail(line,
             "unknown channel name " + show(name) +
                 ": expected Xposition, Yposition, Zposition, Xrotation, Yrotation or Zrotation");
      if (std::find(joint.channels.begin(), joint.channels.end(), *c) != joint.channels.end())
        fail(line, "duplicate channel " + show(name) + " on joint '" + joint.name + "'");
      if (joint.channels.size() < 6) joint.channels.push_back(*c);
    }
    if (listed != count)
      fail(line, "CHANNELS count " + std::to_string(count) + " does not match the " +
                     std::to_string(listed) + " channel names listed");
  }

  // Next token on the current line only (empty at the end of the line).
  std::string_view rest_token_on_line() {
    const char* start = scan_text_until([](char c) { return is_space(c); });
    return {start, static_cast<std::size_t>(p_ - start)};
  }

  // HIERARCHY body: one or more ROOT trees, then MOTION (consumed here).
  // Iterative (explicit stack) so that deep nesting cannot overflow the call stack.
  void parse_hierarchy(RawClip& clip) {
    struct Open {
      int joint;  // -1 for an End Site block
      bool has_offset;
      bool has_channels;
      bool has_children;
    };
    std::vector<Open> stack;
    std::size_t column = 0;
    for (;;) {
      const std::string_view tok = token();
      if (stack.empty()) {
        if (tok == "ROOT") {
          const int root = add_joint(clip, "ROOT", "'{' after ROOT name", -1, column);
          stack.push_back({root, false, false, false});
          continue;
        }
        if (tok == "MOTION") {
          if (clip.joints.empty()) fail(token_line_, "expected ROOT before MOTION");
          break;
        }
        if (tok.empty()) {
          fail(token_line_, clip.joints.empty()
                                ? "truncated hierarchy: expected ROOT"
                                : "missing MOTION: expected MOTION after the hierarchy");
        }
        if (tok == "}") fail(token_line_, "unbalanced braces: '}' without a matching '{'");
        fail(token_line_,
             std::string(clip.joints.empty() ? "expected ROOT" : "expected ROOT or MOTION") +
                 ", found " + show(tok));
      }
      Open& top = stack.back();
      if (tok.empty()) {
        fail(token_line_,
             "truncated hierarchy: expected '}' to close " +
                 (top.joint < 0
                      ? std::string("End Site")
                      : "joint '" + clip.joints[static_cast<std::size_t>(top.joint)].name + "'"));
      }
      if (tok == "}") {
        if (!top.has_offset) fail(token_line_, "expected OFFSET before '}'");
        stack.pop_back();
        continue;
      }
      if (tok == "OFFSET") {
        if (top.has_offset) fail(token_line_, "second OFFSET in one block: expected one OFFSET");
        if (top.has_children) fail(token_line_, "expected OFFSET before child joints");
        const Eigen::Vector3d v = offset_values();
        top.has_offset = true;
        if (top.joint >= 0) {
          clip.joints[static_cast<std::size_t>(top.joint)].offset = v;
        } else {
          clip.joints[static_cast<std::size_t>(stack[stack.size() - 2].joint)].end_site = v;
        }
        continue;
      }
      if (top.joint < 0)
        fail(token_line_, "expected OFFSET or '}' in End Site, found " + show(tok));
      RawJoint& joint = clip.joints[static_cast<std::size_t>(top.joint)];
      if (tok == "CHANNELS") {
        if (top.has_channels) fail(token_line_, "second CHANNELS in joint '" + joint.name + "'");
        if (top.has_children) fail(token_line_, "expected CHANNELS before child joints");
        joint.first_column = column;
        parse_channels(joint);
        column += joint.channels.size();
        top.has_channels = true;
        continue;
      }
      if (tok == "JOINT") {
        if (!top.has_offset) fail(token_line_, "expected OFFSET before JOINT");
        top.has_children = true;
        const int child = add_joint(clip, "JOINT", "'{' after JOINT name", top.joint, column);
        stack.push_back({child, false, false, false});
        continue;
      }
      if (tok == "End") {
        const std::size_t line = token_line_;
        if (!top.has_offset) fail(line, "expected OFFSET before End Site");
        // "End Site": two tokens, possibly with blanks or a line break between them.
        const std::string_view site = token();
        if (site != "Site")
          fail(token_line_, "expected 'Site' after 'End', found " +
                                (site.empty() ? std::string("end of file") : show(site)));
        if (joint.has_end_site) fail(line, "second End Site in joint '" + joint.name + "'");
        joint.has_end_site = true;
        top.has_children = true;
        end_site_name_and_brace();
        stack.push_back({-1, false, false, false});
        continue;
      }
      if (tok == "MOTION" || tok == "ROOT")
        fail(token_line_, "unbalanced braces: expected '}' to close joint '" + joint.name +
                              "' before " + std::string(tok));
      if (tok == "{") fail(token_line_, "unbalanced braces: unexpected '{'");
      fail(token_line_, "expected OFFSET, CHANNELS, JOINT, End Site or '}', found " + show(tok));
    }
    clip.channel_count = column;
  }

  // "Frames: N" (also "Frames:N"): N, and its line in `frames_line`.
  std::size_t parse_frame_count(std::size_t& frames_line) {
    std::string_view tok = token();
    std::string_view count_text;
    if (tok == "Frames:") {
      count_text = token();
    } else if (tok.size() > 7 && tok.substr(0, 7) == "Frames:") {
      count_text = tok.substr(7);
    } else {
      fail(token_line_, "expected 'Frames:' after MOTION, found " +
                            (tok.empty() ? std::string("end of file") : show(tok)));
    }
    frames_line = token_line_;
    std::size_t declared = 0;
    const auto [ptr, ec] =
        std::from_chars(count_text.data(), count_text.data() + count_text.size(), declared);
    if (count_text.empty() || ec != std::errc() || ptr != count_text.data() + count_text.size())
      fail(frames_line, "expected a non-negative whole frame count after 'Frames:', found " +
                            (count_text.empty() ? std::string("end of file") : show(count_text)));
    return declared;
  }

  // "Frame Time: t" (any blanks; also "Frame Time :" and "Frame Time:t"): t
  // in seconds, checked.
  double parse_frame_time() {
    std::string_view tok = token();
    if (tok != "Frame")
      fail(token_line_, "expected 'Frame Time:', found " +
                            (tok.empty() ? std::string("end of file") : show(tok)));
    tok = token();
    std::string_view time_text;
    if (tok == "Time:") {
      time_text = token();
    } else if (tok == "Time") {
      expect(":", "':' after 'Frame Time'");
      time_text = token();
    } else if (tok.size() > 5 && tok.substr(0, 5) == "Time:") {
      time_text = tok.substr(5);
    } else {
      fail(token_line_, "expected 'Frame Time:', found " +
                            (tok.empty() ? std::string("end of file") : show(tok)));
    }
    const std::size_t time_line = token_line_;
    double frame_time = 0.0;
    if (time_text.empty() || parse_double(time_text.data(), time_text.data() + time_text.size(),
                                          frame_time) != time_text.data() + time_text.size())
      fail(time_line, "expected a number after 'Frame Time:', found " +
                          (time_text.empty() ? std::string("end of file") : show(time_text)));
    if (!(frame_time > 0.0) || !std::isfinite(frame_time))
      fail(time_line, "frame time must be a positive number of seconds, found " + show(time_text));
    if (frame_time < kMinFrameTime || frame_time > kMaxFrameTime)
      fail(time_line, "frame time out of range: " + show(time_text) +
                          " s; expected 1e-5 to 60 s (100 kHz to one frame a minute)");
    return frame_time;
  }

  void parse_motion(RawClip& clip) {
    std::size_t frames_line = 0;
    const std::size_t declared = parse_frame_count(frames_line);
    clip.frame_time_s = parse_frame_time();
    clip.frame_count = declared;
    declared_ = declared;

    const std::size_t cc = clip.channel_count;
    // Rest of the "Frame Time" line must be empty.
    skip_blanks();
    if (p_ < end_ && *p_ != '\n')
      fail(line_,
           "expected the end of the 'Frame Time:' line, found " +
               show(std::string_view(p_, static_cast<std::size_t>(end_ - p_)).substr(0, 20)));
    if (cc == 0) {
      skip_space();
      if (p_ != end_)
        fail(line_, "too many values: the hierarchy has no channels, so frame lines must be empty");
      if (declared != 0)
        fail(frames_line, "frame count " + std::to_string(declared) +
                              " needs channels, but the hierarchy has none");
      return;
    }
    parse_frame_lines(clip, declared, frames_line);
  }

  // The frame lines (the window's, when set) into clip.values: `declared`
  // of them (from "Frames:" on line frames_line), nothing after them.
  void parse_frame_lines(RawClip& clip, std::size_t declared, std::size_t frames_line) {
    const std::size_t cc = clip.channel_count;
    // Allocation bounded by the text: a frame line of cc values needs at least 2*cc - 1
    // bytes plus its newline, so the remaining text cannot hold more rows than this.
    const auto remaining = static_cast<std::size_t>(end_ - p_);
    const std::size_t max_rows = remaining / (2 * cc) + 1;
    // Window: rows [first, last) of the file are kept, at row f - first.
    const std::size_t first = window_ ? std::min(first_, declared) : 0;
    const std::size_t last = window_ ? first + std::min(count_, declared - first) : declared;
    std::size_t capacity = std::min(last - first, max_rows);
    clip.values.resize(capacity * cc);

    std::size_t f = 0;
    const char* p = p_;
    const char* const end = end_;
    std::size_t line = line_;
    bool stopped = false;
    for (;;) {
      // Skip blank lines (and the newline ending the previous line).
      while (p < end && is_space(*p)) {
        if (*p == '\n') ++line;
        ++p;
      }
      if (p == end) break;
      if (f == declared) {
        p_ = p;
        line_ = line;
        fail(line, "more frame lines than 'Frames: " + std::to_string(declared) + "' (line " +
                       std::to_string(frames_line) + "): expected the end of the file");
      }
      if (f < first) {  // window: a line before it, skipped unread
        const void* nl = std::memchr(p, '\n', static_cast<std::size_t>(end - p));
        p = nl != nullptr ? static_cast<const char*>(nl) : end;
        ++f;
        continue;
      }
      if (f == last) {  // window: the rest is not looked at
        stopped = true;
        break;
      }
      if (f - first == capacity) {  // cannot happen (see max_rows); stay safe anyway
        capacity = std::min(last - first, capacity * 2 + 1);
        clip.values.resize(capacity * cc);
      }
      p = parse_frame_line(p, line, f, cc, clip.values.data() + (f - first) * cc);
      ++f;
    }
    p_ = p;
    line_ = line;
    if (f != declared && !stopped)
      fail(line, "fewer frame lines (" + std::to_string(f) +
                     ") than 'Frames: " + std::to_string(declared) + "' (line " +
                     std::to_string(frames_line) + "): expected more frames");
    clip.frame_count = f - first;
    clip.values.resize(clip.frame_count * cc);
  }

  // Frame f's line (number `line`) from p: its cc values into `out`.
  // Returns where the line's newline (or the text's end) is.
  const char* parse_frame_line(const char* p, std::size_t line, std::size_t f, std::size_t cc,
                               double* out) const {
    const char* const end = end_;
    for (std::size_t c = 0; c < cc; ++c) {
      p = after_blanks(p, end);
      if (p == end || *p == '\n')
        fail(line, "too few values on frame line: expected " + std::to_string(cc) +
                       " values, found " + std::to_string(c));
      double v;
      const char* stop = parse_double(p, end, v);
      if (stop == nullptr || (stop < end && !is_space(*stop))) {
        const char* tok_end = p;
        while (tok_end < end && !is_space(*tok_end)) ++tok_end;
        fail(line, "expected a number (value " + std::to_string(c + 1) + " of frame " +
                       std::to_string(f) + "), found " +
                       show(std::string_view(p, static_cast<std::size_t>(tok_end - p))));
      }
      if (!std::isfinite(v) || std::abs(v) > kMaxBvhValue)
        fail(line, std::string(std::isfinite(v) ? "value out of range: |value| must be at "
                                                  "most 1e7 (file units or degrees)"
                                                : "expected a finite number") +
                       " (value " + std::to_string(c + 1) + " of frame " + std::to_string(f) + ")");
      out[c] = v;
      p = stop;
    }
    p = after_blanks(p, end);
    if (p < end && *p != '\n')
      fail(line, "too many values on frame line: expected " + std::to_string(cc) + " values");
    return p;
  }

  const char* begin_;
  const char* p_;
  const char* end_;
  bool window_ = false;
  std::size_t first_ = 0, count_ = 0, declared_ = 0;
  std::string source_;
  std::size_t line_ = 1;
  std::size_t token_line_ = 1;
  // Line of each joint name seen (a name given twice is an error).
  std::unordered_map<std::string, std::size_t> joint_lines_;
};

// What parse_bvh_window returns once `parser` has read `clip` (the frames
// from `first` on).
BvhWindow window_of(RawClip clip, const BvhParser& parser, std::size_t first) {
  BvhWindow out;
  out.clip = std::move(clip);
  out.first_frame = std::min(first, parser.declared_frames());
  out.file_frame_count = parser.declared_frames();
  return out;
}

}  // namespace

RawClip parse_bvh(std::string_view text, const std::string& source) {
  return BvhParser(text, source).parse();
}

BvhWindow parse_bvh_window(std::string_view text, const std::string& source, std::size_t first,
                           std::size_t count, BvhHierarchy* hierarchy) {
  BvhParser parser(text, source);
  parser.set_window(first, count);
  if (hierarchy == nullptr) return window_of(parser.parse(), parser, first);
  hierarchy->clip = parser.parse_head();
  hierarchy->clip.source.clear();
  hierarchy->prefix.assign(text.substr(0, parser.head_bytes()));
  hierarchy->motion_line = parser.line();
  return window_of(parser.parse_after(*hierarchy), parser, first);
}

BvhWindow parse_bvh_window(std::string_view text, const std::string& source,
                           const BvhHierarchy& known, std::size_t first, std::size_t count) {
  if (!known.heads(text))
    throw std::invalid_argument("parse_bvh_window: " + source +
                                " does not begin with the given hierarchy");
  BvhParser parser(text, source);
  parser.set_window(first, count);
  return window_of(parser.parse_after(known), parser, first);
}

bool BvhHierarchy::heads(std::string_view text) const {
  // MOTION ends the prefix; a token goes on to the next blank or newline, so
  // the text's hierarchy is the prefix's only when one of those (or the end)
  // follows it.
  return !prefix.empty() && text.size() >= prefix.size() &&
         std::memcmp(text.data(), prefix.data(), prefix.size()) == 0 &&
         (text.size() == prefix.size() || is_space(text[prefix.size()]));
}

RawClip read_bvh_file(const std::filesystem::path& path) {
  const FileBytes text = read_input_file(path, input_limits().bvh_bytes);
  return parse_bvh(text.view(), path.string());
}

}  // namespace mocap
