#include "mocap/bvh.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <limits>
#include <optional>
#include <random>
#include <span>
#include <stdexcept>
#include <system_error>

#include "mocap/error.hpp"
#include "mocap/kinematics.hpp"

namespace mocap {

namespace {

// ---------------------------------------------------------------------------
// Reader
// ---------------------------------------------------------------------------

constexpr double kInf = std::numeric_limits<double>::infinity();

// Blanks inside a line. '\r' counts as one so that CRLF files need no special case.
inline bool is_blank(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\f' || c == '\v'; }
inline bool is_space(char c) { return is_blank(c) || c == '\n'; }
// Bytes that never occur in a text file: control characters other than blanks, DEL.
inline bool is_binary(char c) {
  const auto u = static_cast<unsigned char>(c);
  return (u < 0x20 && !is_space(c)) || u == 0x7f;
}

std::string show(std::string_view s) {
  std::string out = "'";
  for (char c : s.substr(0, 40)) {
    if (is_binary(c)) {
      char buf[8];
      std::snprintf(buf, sizeof buf, "\\x%02x", static_cast<unsigned>(static_cast<unsigned char>(c)));
      out += buf;
    } else {
      out += c;
    }
  }
  if (s.size() > 40) out += "...";
  out += "'";
  return out;
}

std::optional<Channel> channel_from_name(std::string_view s) {
  if (s.size() != 9) return std::nullopt;
  constexpr Channel kChannels[] = {Channel::Xposition, Channel::Yposition, Channel::Zposition,
                                   Channel::Xrotation, Channel::Yrotation, Channel::Zrotation};
  for (Channel c : kChannels)
    if (s == channel_name(c)) return c;
  return std::nullopt;
}

// std::from_chars for what the fast path below does not take ('+' skipped here).
[[gnu::noinline]] const char* parse_double_slow(const char* p, const char* end, double& out) {
  // from_chars takes '-' but not '+'.
  const char* start = (p < end && *p == '+') ? p + 1 : p;
  if (start < end && *start == '-' && p != start) return nullptr;  // "+-1"
  const auto [ptr, ec] = std::from_chars(start, end, out);
  if (ec != std::errc() || ptr == start) return nullptr;
  return ptr;
}

// Parses one number at p (a leading '+' is allowed; from_chars does not take it).
// Returns the end of the number, or nullptr when there is none.
//
// Fast path (Clinger): a decimal "[+-]digits[.digits][e[+-]digits]" whose
// digits form an integer m <= 2^53 and whose value is m * 10^s with |s| <= 22
// is one IEEE multiplication or division of two exact doubles, which is
// correctly rounded, so the result equals from_chars'. Everything else (long
// mantissas, big exponents, inf/nan, garbage) goes to std::from_chars. The fast
// path took set 2 from ~230 to ~300 MB/s: libstdc++'s from_chars was 40% of
// the parse time.
[[gnu::always_inline]] inline const char* parse_double(const char* p, const char* end, double& out) {
  static constexpr double kPow10[] = {1e0,  1e1,  1e2,  1e3,  1e4,  1e5,  1e6,  1e7,  1e8,  1e9,  1e10, 1e11,
                                      1e12, 1e13, 1e14, 1e15, 1e16, 1e17, 1e18, 1e19, 1e20, 1e21, 1e22};
  const char* q = p;
  bool negative = false;
  if (q < end && (*q == '+' || *q == '-')) {
    negative = *q == '-';
    ++q;
  }
  std::uint64_t m = 0;
  int digits = 0;
  while (q < end && static_cast<unsigned char>(*q - '0') < 10 && digits < 18) {
    m = m * 10 + static_cast<std::uint64_t>(*q - '0');
    ++digits;
    ++q;
  }
  int fraction = 0;
  if (q < end && *q == '.') {
    ++q;
    while (q < end && static_cast<unsigned char>(*q - '0') < 10 && digits < 18) {
      m = m * 10 + static_cast<std::uint64_t>(*q - '0');
      ++digits;
      ++fraction;
      ++q;
    }
  }
  int exponent = 0;
  if (q < end && (*q == 'e' || *q == 'E') && digits > 0) {
    const char* e = q + 1;
    bool exp_negative = false;
    if (e < end && (*e == '+' || *e == '-')) {
      exp_negative = *e == '-';
      ++e;
    }
    int exp_digits = 0;
    while (e < end && static_cast<unsigned char>(*e - '0') < 10 && exp_digits < 4) {
      exponent = exponent * 10 + (*e - '0');
      ++exp_digits;
      ++e;
    }
    if (exp_digits == 0 || exp_digits == 4) {
      digits = 0;  // malformed or huge exponent: slow path decides
    } else {
      if (exp_negative) exponent = -exponent;
      q = e;
    }
  }
  const bool more = q < end && (static_cast<unsigned char>(*q - '0') < 10 || *q == '.' || *q == 'e' ||
                                *q == 'E' || *q == 'n' || *q == 'N' || *q == 'i' || *q == 'I');
  const int scale = exponent - fraction;  // value = m * 10^scale
  if (digits > 0 && !more && m <= (std::uint64_t{1} << 53) && scale >= -22 && scale <= 22) {
    const double v = scale < 0 ? static_cast<double>(m) / kPow10[-scale] : static_cast<double>(m) * kPow10[scale];
    out = negative ? -v : v;
    return q;
  }
  return parse_double_slow(p, end, out);
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

  void skip_blanks() {
    while (p_ < end_ && is_blank(*p_)) ++p_;
  }

  // Next whitespace-separated token (empty at the end of the text); its line is token_line_.
  std::string_view token() {
    skip_space();
    token_line_ = line_;
    const char* start = p_;
    while (p_ < end_ && !is_space(*p_)) {
      if (is_binary(*p_))
        fail(line_, "binary data (byte " + show(std::string_view(p_, 1)) + "): expected BVH text");
      ++p_;
    }
    return {start, static_cast<std::size_t>(p_ - start)};
  }

  // Rest of the current line without surrounding blanks (joint names may hold spaces).
  std::string_view rest_of_line() {
    skip_blanks();
    const char* start = p_;
    while (p_ < end_ && *p_ != '\n') {
      if (is_binary(*p_))
        fail(line_, "binary data (byte " + show(std::string_view(p_, 1)) + "): expected BVH text");
      ++p_;
    }
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
    if (!std::isfinite(v)) fail(token_line_, std::string("expected a finite number (") + what + ")");
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

  void parse_channels(RawJoint& joint) {
    const std::size_t line = token_line_;
    skip_blanks();
    const std::string_view count_tok = rest_token_on_line();
    if (count_tok.empty()) fail(line, "expected the channel count after CHANNELS");
    unsigned count = 0;
    const auto [ptr, ec] = std::from_chars(count_tok.data(), count_tok.data() + count_tok.size(), count);
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
        fail(line, "unknown channel name " + show(name) +
                       ": expected Xposition, Yposition, Zposition, Xrotation, Yrotation or Zrotation");
      if (std::find(joint.channels.begin(), joint.channels.end(), *c) != joint.channels.end())
        fail(line, "duplicate channel " + show(name) + " on joint '" + joint.name + "'");
      if (joint.channels.size() < 6) joint.channels.push_back(*c);
    }
    if (listed != count)
      fail(line, "CHANNELS count " + std::to_string(count) + " does not match the " + std::to_string(listed) +
                     " channel names listed");
  }

  // Next token on the current line only (empty at the end of the line).
  std::string_view rest_token_on_line() {
    const char* start = p_;
    while (p_ < end_ && !is_space(*p_)) {
      if (is_binary(*p_))
        fail(line_, "binary data (byte " + show(std::string_view(p_, 1)) + "): expected BVH text");
      ++p_;
    }
    return {start, static_cast<std::size_t>(p_ - start)};
  }

  // HIERARCHY body: one or more ROOT trees, then MOTION (consumed here).
  // Iterative (explicit stack) so that deep nesting cannot overflow the call stack.
  void parse_hierarchy(RawClip& clip) {
    struct Open {
      int joint;            // -1 for an End Site block
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
          bool opened = false;
          RawJoint j;
          j.name = joint_name("ROOT", opened);
          j.parent = -1;
          j.first_column = column;
          if (!opened) expect("{", "'{' after ROOT name");
          clip.joints.push_back(std::move(j));
          stack.push_back({static_cast<int>(clip.joints.size() - 1), false, false, false});
          continue;
        }
        if (tok == "MOTION") {
          if (clip.joints.empty()) fail(token_line_, "expected ROOT before MOTION");
          break;
        }
        if (tok.empty()) {
          fail(token_line_, clip.joints.empty() ? "truncated hierarchy: expected ROOT"
                                                : "missing MOTION: expected MOTION after the hierarchy");
        }
        if (tok == "}") fail(token_line_, "unbalanced braces: '}' without a matching '{'");
        fail(token_line_, std::string(clip.joints.empty() ? "expected ROOT" : "expected ROOT or MOTION") +
                              ", found " + show(tok));
      }
      Open& top = stack.back();
      if (tok.empty()) {
        fail(token_line_, "truncated hierarchy: expected '}' to close " +
                              (top.joint < 0 ? std::string("End Site")
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
      if (top.joint < 0) fail(token_line_, "expected OFFSET or '}' in End Site, found " + show(tok));
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
        const int parent = top.joint;
        bool opened = false;
        RawJoint j;
        j.name = joint_name("JOINT", opened);
        j.parent = parent;
        j.first_column = column;
        if (!opened) expect("{", "'{' after JOINT name");
        clip.joints.push_back(std::move(j));
        stack.push_back({static_cast<int>(clip.joints.size() - 1), false, false, false});
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
        expect("{", "'{' after End Site");
        stack.push_back({-1, false, false, false});
        continue;
      }
      if (tok == "MOTION" || tok == "ROOT")
        fail(token_line_, "unbalanced braces: expected '}' to close joint '" + joint.name + "' before " +
                              std::string(tok));
      if (tok == "{") fail(token_line_, "unbalanced braces: unexpected '{'");
      fail(token_line_, "expected OFFSET, CHANNELS, JOINT, End Site or '}', found " + show(tok));
    }
    clip.channel_count = column;
  }

  void parse_motion(RawClip& clip) {
    // "Frames: N" (also "Frames:N").
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
    const std::size_t frames_line = token_line_;
    std::size_t declared = 0;
    {
      const auto [ptr, ec] = std::from_chars(count_text.data(), count_text.data() + count_text.size(), declared);
      if (count_text.empty() || ec != std::errc() || ptr != count_text.data() + count_text.size())
        fail(frames_line, "expected a non-negative whole frame count after 'Frames:', found " +
                              (count_text.empty() ? std::string("end of file") : show(count_text)));
    }
    // "Frame Time: t" (any blanks; also "Frame Time :" and "Frame Time:t").
    tok = token();
    if (tok != "Frame")
      fail(token_line_, "expected 'Frame Time:', found " + (tok.empty() ? std::string("end of file") : show(tok)));
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
      fail(token_line_, "expected 'Frame Time:', found " + (tok.empty() ? std::string("end of file") : show(tok)));
    }
    const std::size_t time_line = token_line_;
    double frame_time = 0.0;
    if (time_text.empty() ||
        parse_double(time_text.data(), time_text.data() + time_text.size(), frame_time) !=
            time_text.data() + time_text.size())
      fail(time_line, "expected a number after 'Frame Time:', found " +
                          (time_text.empty() ? std::string("end of file") : show(time_text)));
    if (!(frame_time > 0.0) || !std::isfinite(frame_time))
      fail(time_line, "frame time must be a positive number of seconds, found " + show(time_text));
    clip.frame_time_s = frame_time;
    clip.frame_count = declared;
    declared_ = declared;

    const std::size_t cc = clip.channel_count;
    // Rest of the "Frame Time" line must be empty.
    skip_blanks();
    if (p_ < end_ && *p_ != '\n') fail(line_, "expected the end of the 'Frame Time:' line, found " +
                                                  show(std::string_view(p_, static_cast<std::size_t>(end_ - p_)).substr(0, 20)));
    if (cc == 0) {
      skip_space();
      if (p_ != end_)
        fail(line_, "too many values: the hierarchy has no channels, so frame lines must be empty");
      if (declared != 0)
        fail(frames_line, "frame count " + std::to_string(declared) + " needs channels, but the hierarchy has none");
      return;
    }
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
      double* out = clip.values.data() + (f - first) * cc;
      for (std::size_t c = 0; c < cc; ++c) {
        while (p < end && is_blank(*p)) ++p;
        if (p == end || *p == '\n')
          fail(line, "too few values on frame line: expected " + std::to_string(cc) + " values, found " +
                         std::to_string(c));
        double v;
        const char* stop = parse_double(p, end, v);
        if (stop == nullptr || (stop < end && !is_space(*stop))) {
          const char* tok_end = p;
          while (tok_end < end && !is_space(*tok_end)) ++tok_end;
          fail(line, "expected a number (value " + std::to_string(c + 1) + " of frame " + std::to_string(f) +
                         "), found " + show(std::string_view(p, static_cast<std::size_t>(tok_end - p))));
        }
        if (!std::isfinite(v))
          fail(line, "expected a finite number (value " + std::to_string(c + 1) + " of frame " +
                         std::to_string(f) + ")");
        out[c] = v;
        p = stop;
      }
      while (p < end && is_blank(*p)) ++p;
      if (p < end && *p != '\n')
        fail(line, "too many values on frame line: expected " + std::to_string(cc) + " values");
      ++f;
    }
    p_ = p;
    line_ = line;
    if (f != declared && !stopped)
      fail(line, "fewer frame lines (" + std::to_string(f) + ") than 'Frames: " + std::to_string(declared) +
                     "' (line " + std::to_string(frames_line) + "): expected more frames");
    clip.frame_count = f - first;
    clip.values.resize(clip.frame_count * cc);
  }

  const char* begin_;
  const char* p_;
  const char* end_;
  bool window_ = false;
  std::size_t first_ = 0, count_ = 0, declared_ = 0;
  std::string source_;
  std::size_t line_ = 1;
  std::size_t token_line_ = 1;
};

// ---------------------------------------------------------------------------
// Writer
// ---------------------------------------------------------------------------

// Checks the invariants the writer relies on (a hand-built clip may break them).
void check_clip(const RawClip& clip) {
  const std::size_t n = clip.joints.size();
  if (n == 0) throw InputError(clip.source, 0, "clip has no joints: expected at least one ROOT");
  for (std::size_t j = 0; j < n; ++j) {
    const RawJoint& rj = clip.joints[j];
    if (rj.parent >= static_cast<int>(j) || rj.parent < -1)
      throw InputError(clip.source, 0, "joint '" + rj.name + "' must come after its parent");
    if (rj.name.empty() || rj.name.find_first_of("\r\n{}") != std::string::npos || is_blank(rj.name.front()) ||
        is_blank(rj.name.back()) || std::any_of(rj.name.begin(), rj.name.end(), is_binary))
      throw InputError(clip.source, 0, "joint name " + show(rj.name) + " cannot be written to BVH");
    if (rj.first_column + rj.channels.size() > clip.channel_count)
      throw InputError(clip.source, 0, "joint '" + rj.name + "' has channels past the frame row");
    if (rj.channels.size() > 6) throw InputError(clip.source, 0, "joint '" + rj.name + "' has more than 6 channels");
  }
  if (clip.values.size() != clip.frame_count * clip.channel_count)
    throw InputError(clip.source, 0, "values size does not match frame_count x channel_count");
  if (!(clip.frame_time_s > 0.0) || !std::isfinite(clip.frame_time_s))
    throw InputError(clip.source, 0, "frame time must be a positive number of seconds");
}

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

RawClip parse_bvh(std::string_view text, const std::string& source) {
  return BvhParser(text, source).parse();
}

BvhWindow parse_bvh_window(std::string_view text, const std::string& source, std::size_t first,
                           std::size_t count, BvhHierarchy* hierarchy) {
  BvhParser parser(text, source);
  parser.set_window(first, count);
  BvhWindow out;
  if (hierarchy == nullptr) {
    out.clip = parser.parse();
  } else {
    hierarchy->clip = parser.parse_head();
    hierarchy->clip.source.clear();
    hierarchy->prefix.assign(text.substr(0, parser.head_bytes()));
    hierarchy->motion_line = parser.line();
    out.clip = parser.parse_after(*hierarchy);
  }
  out.first_frame = std::min(first, parser.declared_frames());
  out.file_frame_count = parser.declared_frames();
  return out;
}

BvhWindow parse_bvh_window(std::string_view text, const std::string& source,
                           const BvhHierarchy& known, std::size_t first, std::size_t count) {
  if (!known.heads(text))
    throw std::invalid_argument("parse_bvh_window: " + source +
                                " does not begin with the given hierarchy");
  BvhParser parser(text, source);
  parser.set_window(first, count);
  BvhWindow out;
  out.clip = parser.parse_after(known);
  out.first_frame = std::min(first, parser.declared_frames());
  out.file_frame_count = parser.declared_frames();
  return out;
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
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path.string(), 0, "cannot open file for reading");
  std::error_code ec;
  const auto size = std::filesystem::file_size(path, ec);
  std::string text;
  if (!ec) {
    text.resize(static_cast<std::size_t>(size));
    in.read(text.data(), static_cast<std::streamsize>(size));
    text.resize(static_cast<std::size_t>(in.gcount()));
  }
  if (ec || in.bad()) throw InputError(path.string(), 0, "cannot read file");
  return parse_bvh(text, path.string());
}

std::string write_bvh(const RawClip& clip, int precision) {
  check_clip(clip);
  const std::size_t n = clip.joints.size();
  std::vector<std::vector<std::size_t>> children(n);
  for (std::size_t j = 0; j < n; ++j)
    if (clip.joints[j].parent >= 0) children[static_cast<std::size_t>(clip.joints[j].parent)].push_back(j);

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
        if (!j.channels.empty()) {
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
          throw InputError(clip.source, 0, "non-finite value at frame " + std::to_string(f) + ", joint '" +
                                               rj.name + "'");
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
    if (!out) throw InputError(path.string(), 0, "cannot open a temporary file next to it for writing");
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

// ---------------------------------------------------------------------------
// Export layout
// ---------------------------------------------------------------------------

namespace {

// A joint's translation in its parent's frame at one frame row: position
// channels replace the OFFSET's components (skeleton.hpp), file units.
Eigen::Vector3d joint_translation(const RawJoint& j, const double* row) {
  Eigen::Vector3d t = j.offset;
  for (std::size_t c = 0; c < j.channels.size(); ++c)
    if (!channel_is_rotation(j.channels[c])) t[channel_axis(j.channels[c])] = row[j.first_column + c];
  return t;
}

Eigen::Quaterniond joint_rotation(const RawJoint& j, const double* row) {
  std::array<std::uint8_t, 3> axes{};
  std::array<double, 3> degrees{};
  std::size_t k = 0;
  for (std::size_t c = 0; c < j.channels.size() && k < 3; ++c)
    if (channel_is_rotation(j.channels[c])) {
      axes[k] = static_cast<std::uint8_t>(channel_axis(j.channels[c]));
      degrees[k] = row[j.first_column + c];
      ++k;
    }
  return euler_to_quaternion(std::span<const std::uint8_t>(axes.data(), k),
                             std::span<const double>(degrees.data(), k));
}

}  // namespace

RawClip to_export_layout(const RawClip& clip, double tolerance) {
  check_clip(clip);
  const std::size_t n = clip.joints.size();
  const std::size_t frames = clip.frame_count;

  std::vector<std::size_t> child_count(n, 0);
  for (const RawJoint& j : clip.joints)
    if (j.parent >= 0) ++child_count[static_cast<std::size_t>(j.parent)];

  // Which non-root joints have position channels that vary by more than tolerance.
  std::vector<std::uint8_t> varies(n, 0);
  for (std::size_t j = 0; j < n; ++j) {
    const RawJoint& rj = clip.joints[j];
    if (rj.parent < 0) continue;
    for (std::size_t c = 0; c < rj.channels.size(); ++c) {
      if (channel_is_rotation(rj.channels[c])) continue;
      double lo = kInf, hi = -kInf;
      for (std::size_t f = 0; f < frames; ++f) {
        const double v = clip.frame(f)[rj.first_column + c];
        lo = std::min(lo, v);
        hi = std::max(hi, v);
      }
      if (frames > 0 && hi - lo > tolerance) varies[j] = 1;
    }
  }

  // A varying joint can be "lifted": when the path from its root down to its
  // parent is a bare chain (each joint there has exactly this one child and no
  // End Site; the joints between have constant positions), moving the root by
  //   d(f) = R_world(parent)(f) * (t(f) - t(0))
  // and giving the joint the constant translation t(0) keeps the world
  // positions of the joint and its whole subtree; only the chain above moves
  // with the root. This is Bandai Namco's static joint_Root above a moving Hips.
  std::vector<int> lifted(n, -1);  // per root: the lifted joint, -1 none
  for (std::size_t j = 0; j < n; ++j) {
    if (!varies[j]) continue;
    const RawJoint& rj = clip.joints[j];
    bool chain = true;
    int root = rj.parent;
    for (int a = rj.parent; a >= 0; a = clip.joints[static_cast<std::size_t>(a)].parent) {
      const auto ai = static_cast<std::size_t>(a);
      if (child_count[ai] != 1 || clip.joints[ai].has_end_site || (varies[ai] && clip.joints[ai].parent >= 0))
        chain = false;
      root = a;
    }
    const auto ri = static_cast<std::size_t>(root);
    if (!chain || lifted[ri] >= 0)
      throw InputError(clip.source, 0,
                       "joint '" + rj.name + "' has position channels that vary by more than " +
                           std::to_string(tolerance) +
                           " file units; expected constant positions on non-root joints");
    lifted[ri] = static_cast<int>(j);
  }

  RawClip out;
  out.source = clip.source;
  out.frame_time_s = clip.frame_time_s;
  out.frame_count = frames;
  out.joints.resize(n);
  // Source columns of each output channel (-1: constant zero angle).
  std::vector<std::vector<int>> source_columns(n);
  std::size_t column = 0;
  for (std::size_t j = 0; j < n; ++j) {
    const RawJoint& rj = clip.joints[j];
    RawJoint& oj = out.joints[j];
    oj.name = rj.name;
    oj.parent = rj.parent;
    oj.has_end_site = rj.has_end_site;
    oj.end_site = rj.end_site;
    oj.first_column = column;
    std::vector<int>& src = source_columns[j];
    std::array<bool, 3> have_axis{false, false, false};
    std::vector<Channel> rotations;
    std::vector<int> rotation_columns;
    for (std::size_t c = 0; c < rj.channels.size(); ++c) {
      const Channel ch = rj.channels[c];
      if (!channel_is_rotation(ch)) continue;
      const int axis = channel_axis(ch);
      if (have_axis[static_cast<std::size_t>(axis)])
        throw InputError(clip.source, 0, "joint '" + rj.name + "' repeats the rotation channel " +
                                             std::string(channel_name(ch)));
      have_axis[static_cast<std::size_t>(axis)] = true;
      rotations.push_back(ch);
      rotation_columns.push_back(static_cast<int>(rj.first_column + c));
    }
    if (rotations.empty()) {
      rotations = {Channel::Zrotation, Channel::Xrotation, Channel::Yrotation};
      rotation_columns = {-1, -1, -1};
    } else {
      // Zero-angle rotations are the identity wherever they go: append them.
      constexpr Channel kAxisRotation[3] = {Channel::Xrotation, Channel::Yrotation, Channel::Zrotation};
      for (std::size_t a = 0; a < 3; ++a)
        if (!have_axis[a]) {
          rotations.push_back(kAxisRotation[a]);
          rotation_columns.push_back(-1);
        }
    }
    if (rj.parent < 0) {
      oj.offset = Eigen::Vector3d::Zero();
      oj.channels = {Channel::Xposition, Channel::Yposition, Channel::Zposition};
      src = {-1, -1, -1};  // filled per frame below
    } else {
      Eigen::Vector3d offset = rj.offset;
      for (std::size_t c = 0; c < rj.channels.size(); ++c) {
        if (channel_is_rotation(rj.channels[c]) || frames == 0) continue;
        const std::size_t col = rj.first_column + c;
        double lo = kInf, hi = -kInf;
        for (std::size_t f = 0; f < frames; ++f) {
          lo = std::min(lo, clip.frame(f)[col]);
          hi = std::max(hi, clip.frame(f)[col]);
        }
        offset[channel_axis(rj.channels[c])] = varies[j] ? clip.frame(0)[col] : 0.5 * (lo + hi);
      }
      oj.offset = offset;
    }
    oj.channels.insert(oj.channels.end(), rotations.begin(), rotations.end());
    src.insert(src.end(), rotation_columns.begin(), rotation_columns.end());
    column += oj.channels.size();
  }
  out.channel_count = column;
  out.values.assign(frames * column, 0.0);

  for (std::size_t f = 0; f < frames; ++f) {
    const double* row = clip.frame(f);
    double* orow = out.values.data() + f * column;
    for (std::size_t j = 0; j < n; ++j) {
      const RawJoint& oj = out.joints[j];
      const std::vector<int>& src = source_columns[j];
      for (std::size_t c = 0; c < src.size(); ++c)
        if (src[c] >= 0) orow[oj.first_column + c] = row[static_cast<std::size_t>(src[c])];
      if (oj.parent >= 0) continue;
      Eigen::Vector3d p = joint_translation(clip.joints[j], row);
      if (lifted[j] >= 0) {
        // Rotation of the lifted joint's parent in the root's parent (world) frame.
        const auto lj = static_cast<std::size_t>(lifted[j]);
        Eigen::Quaterniond q = Eigen::Quaterniond::Identity();
        std::vector<std::size_t> path;
        for (int a = clip.joints[lj].parent; a >= 0; a = clip.joints[static_cast<std::size_t>(a)].parent)
          path.push_back(static_cast<std::size_t>(a));
        for (auto it = path.rbegin(); it != path.rend(); ++it) q = q * joint_rotation(clip.joints[*it], row);
        const RawJoint& lifted_joint = clip.joints[lj];
        p += q * (joint_translation(lifted_joint, row) - joint_translation(lifted_joint, clip.frame(0)));
      }
      for (int a = 0; a < 3; ++a) orow[oj.first_column + static_cast<std::size_t>(a)] = p[a];
    }
  }
  return out;
}

}  // namespace mocap
