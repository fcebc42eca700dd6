// ASF/AMC reading and conversion to RawClip (asf_amc.hpp, docs/asf-amc.md).
//
// Both formats are line-oriented: a line of blank-separated tokens, '#' lines
// are comments. ASF files are tiny, so the ASF parser reads its lines into a
// vector first; the AMC parser walks the text once, reusing one token vector.
#include "mocap/common/io/asf_amc.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstring>
#include <limits>
#include <numbers>
#include <stdexcept>
#include <unordered_map>

#include "io/bvh_text.hpp"
#include "mocap/common/dynamics/kinematics.hpp"
#include "mocap/common/util/error.hpp"
#include "mocap/common/util/file.hpp"
#include "mocap/common/util/input_limits.hpp"

namespace mocap {
namespace {

using detail::show;

constexpr double kDegPerRad = 180.0 / std::numbers::pi;

struct Line {
  std::size_t number = 0;
  std::vector<std::string_view> tokens;
};

// Byte classes of detail::is_blank and detail::is_binary in one table lookup
// ('\n' never occurs inside a line).
constexpr std::uint8_t kText = 0, kBlank = 1, kBinary = 2;
constexpr std::array<std::uint8_t, 256> kByteClasses = [] {
  std::array<std::uint8_t, 256> t{};
  for (int u = 0; u < 256; ++u) {
    const bool blank = u == ' ' || u == '\t' || u == '\r' || u == '\f' || u == '\v';
    t[static_cast<std::size_t>(u)] = blank                                    ? kBlank
                                     : ((u < 0x20 && u != '\n') || u == 0x7f) ? kBinary
                                                                              : kText;
  }
  return t;
}();
inline std::uint8_t byte_class(char c) {
  return kByteClasses[static_cast<unsigned char>(c)];
}

// Splits the next non-empty, non-comment line of text[pos..] into `out`.
// Returns false at the end of the text. `line` counts lines (1-based).
class LineReader {
 public:
  LineReader(std::string_view text, const std::string& source) : text_(text), source_(source) {}

  bool next(Line& out) {
    while (pos_ < text_.size()) {
      const std::size_t end = std::min(text_.find('\n', pos_), text_.size());
      ++line_;
      out.number = line_;
      out.tokens.clear();
      const char* p = text_.data() + pos_;
      const char* e = text_.data() + end;
      pos_ = end + 1;
      while (true) {
        while (p < e && byte_class(*p) == kBlank) ++p;
        if (p == e) break;
        const char* q = p;
        for (; q < e; ++q) {
          const std::uint8_t c = byte_class(*q);
          if (c == kBlank) break;
          if (c == kBinary) throw InputError(source_, line_, "expected text, found a binary byte");
        }
        out.tokens.emplace_back(p, static_cast<std::size_t>(q - p));
        p = q;
      }
      if (!out.tokens.empty() && out.tokens[0][0] != '#') return true;
    }
    return false;
  }

 private:
  std::string_view text_;
  const std::string& source_;
  std::size_t pos_ = 0;
  std::size_t line_ = 0;
};

double to_number(std::string_view token, const std::string& source, std::size_t line,
                 const char* what) {
  double v = 0.0;
  const char* end = token.data() + token.size();
  const char* q = detail::parse_double(token.data(), end, v);
  if (q != end || !std::isfinite(v))
    throw InputError(source, line,
                     std::string("expected a number (") + what + "), found " + show(token));
  return v;
}

// A limit bound: a number, or inf / -inf.
double to_bound(std::string_view token, const std::string& source, std::size_t line) {
  if (token == "inf" || token == "+inf") return std::numeric_limits<double>::infinity();
  if (token == "-inf") return -std::numeric_limits<double>::infinity();
  return to_number(token, source, line, "a limit");
}

bool iequals(std::string_view a, std::string_view b) {
  if (a.size() != b.size()) return false;
  for (std::size_t i = 0; i < a.size(); ++i)
    if (std::tolower(static_cast<unsigned char>(a[i])) !=
        std::tolower(static_cast<unsigned char>(b[i])))
      return false;
  return true;
}

bool is_rotation(AsfDof d) {
  return d == AsfDof::rx || d == AsfDof::ry || d == AsfDof::rz;
}
int dof_axis(AsfDof d) {
  return static_cast<int>(d) % 3;
}

bool parse_dof(std::string_view t, AsfDof& out) {
  static constexpr std::pair<const char*, AsfDof> kNames[] = {
      {"tx", AsfDof::tx}, {"ty", AsfDof::ty}, {"tz", AsfDof::tz},
      {"rx", AsfDof::rx}, {"ry", AsfDof::ry}, {"rz", AsfDof::rz}};
  for (const auto& [name, dof] : kNames)
    if (iequals(t, name)) {
      out = dof;
      return true;
    }
  return false;
}

std::array<std::uint8_t, 3> parse_axis_order(std::string_view t, const std::string& source,
                                             std::size_t line) {
  std::array<std::uint8_t, 3> order{};
  bool seen[3] = {false, false, false};
  bool ok = t.size() == 3;
  for (std::size_t i = 0; ok && i < 3; ++i) {
    const int a = std::toupper(static_cast<unsigned char>(t[i])) - 'X';
    ok = a >= 0 && a < 3 && !seen[a];
    if (ok) {
      seen[a] = true;
      order[i] = static_cast<std::uint8_t>(a);
    }
  }
  if (!ok)
    throw InputError(source, line,
                     "expected a rotation order of X, Y and Z such as XYZ, found " + show(t));
  return order;
}

Eigen::Vector3d parse_vector(const Line& l, std::size_t first, const std::string& source,
                             const char* what) {
  if (l.tokens.size() < first + 3)
    throw InputError(source, l.number, std::string("expected 3 numbers after ") + what);
  return {to_number(l.tokens[first], source, l.number, what),
          to_number(l.tokens[first + 1], source, l.number, what),
          to_number(l.tokens[first + 2], source, l.number, what)};
}

void expect_count(const Line& l, std::size_t count, const std::string& source) {
  if (l.tokens.size() != count)
    throw InputError(source, l.number,
                     "expected " + std::to_string(count - 1) + " value(s) after " +
                         show(l.tokens[0]) + ", found " + std::to_string(l.tokens.size() - 1));
}

bool is_section(const Line& l) {
  return l.tokens[0][0] == ':';
}

std::string join(const Line& l, std::size_t first) {
  std::string s;
  for (std::size_t i = first; i < l.tokens.size(); ++i) {
    if (!s.empty()) s += ' ';
    s += l.tokens[i];
  }
  return s;
}

// The rotation of the three angles (degrees, about X, Y, Z) applied in `order`,
// first axis first: R = R(order[2]) * R(order[1]) * R(order[0]).
Eigen::Quaterniond ordered_rotation(const std::array<std::uint8_t, 3>& order,
                                    const Eigen::Vector3d& deg) {
  // A zero angle is the identity (exactly: cos 0 = 1, sin 0 = 0), so it is
  // skipped; bones without a dof about an axis save a sincos and a product.
  Eigen::Quaterniond q = Eigen::Quaterniond::Identity();
  for (const std::uint8_t a : order)
    if (deg[a] != 0.0)
      q = Eigen::Quaterniond(Eigen::AngleAxisd(deg[a] / kDegPerRad, Eigen::Vector3d::Unit(a))) * q;
  return q;
}

// quaternion_to_euler(q, {2, 1, 0}) (kinematics.cpp: Euler degrees for
// R = Rz(a) * Ry(b) * Rx(c)) computing only the five matrix entries it reads,
// with Eigen's toRotationMatrix formulas, so the result is bit for bit the
// same (the build has -ffp-contract=off). The conversion calls it once per
// bone and frame.
Eigen::Vector3d quaternion_to_euler_zyx(const Eigen::Quaterniond& q) {
  const Eigen::Quaterniond n = q.normalized();
  const double tx = 2.0 * n.x(), ty = 2.0 * n.y(), tz = 2.0 * n.z();
  const double twx = tx * n.w(), twy = ty * n.w(), twz = tz * n.w();
  const double txx = tx * n.x(), txy = ty * n.x(), txz = tz * n.x();
  const double tyy = ty * n.y(), tyz = tz * n.y(), tzz = tz * n.z();
  const double sb = std::clamp(-(txz - twy), -1.0, 1.0);  // -r(2,0)
  const double b = std::asin(sb);
  double a, c;
  if (std::abs(sb) < 1.0 - 1e-12) {
    a = std::atan2(txy + twz, 1.0 - (tyy + tzz));  // r(1,0), r(0,0)
    c = std::atan2(tyz + twx, 1.0 - (txx + tyy));  // r(2,1), r(2,2)
  } else {
    c = 0.0;
    a = std::atan2(-(txy - twz), 1.0 - (txx + tzz));  // -r(0,1), r(1,1)
  }
  return {a * kDegPerRad, b * kDegPerRad, c * kDegPerRad};
}

// ---------------------------------------------------------------------------
// ASF

class AsfParser {
 public:
  AsfParser(std::string_view text, const std::string& source) : source_(source) {
    LineReader reader(text, source);
    Line l;
    while (reader.next(l)) lines_.push_back(l);
    end_line_ = lines_.empty() ? 1 : lines_.back().number;
  }

  AsfSkeleton run() {
    s_.source = source_;
    bool seen_root = false, seen_bonedata = false, seen_hierarchy = false, seen_units = false;
    while (i_ < lines_.size()) {
      const Line& l = lines_[i_];
      const std::string_view kw = l.tokens[0];
      auto once = [&](bool& seen) {
        if (seen) throw InputError(source_, l.number, "section " + show(kw) + " appears twice");
        seen = true;
      };
      ++i_;
      if (kw == ":version") {
        s_.version = join(l, 1);
      } else if (kw == ":name") {
        s_.name = join(l, 1);
      } else if (kw == ":units") {
        once(seen_units);
        units();
      } else if (kw == ":documentation") {
        while (i_ < lines_.size() && !is_section(lines_[i_])) ++i_;
      } else if (kw == ":root") {
        once(seen_root);
        root();
      } else if (kw == ":bonedata") {
        once(seen_bonedata);
        bonedata();
      } else if (kw == ":hierarchy") {
        once(seen_hierarchy);
        hierarchy_line_ = l.number;
        hierarchy();
      } else {
        throw InputError(source_, l.number,
                         "expected a section (:version, :name, :units, :documentation, :root, "
                         ":bonedata or :hierarchy), found " +
                             show(kw));
      }
    }
    if (!seen_root) throw InputError(source_, end_line_, "missing section :root");
    if (!seen_bonedata) throw InputError(source_, end_line_, "missing section :bonedata");
    if (!seen_hierarchy) throw InputError(source_, end_line_, "missing section :hierarchy");
    link();
    if (!s_.angle_in_degrees) to_degrees();
    return std::move(s_);
  }

 private:
  void units() {
    for (; i_ < lines_.size() && !is_section(lines_[i_]); ++i_) {
      const Line& l = lines_[i_];
      expect_count(l, 2, source_);
      if (l.tokens[0] == "mass") {
        s_.mass = to_number(l.tokens[1], source_, l.number, "mass");
      } else if (l.tokens[0] == "length") {
        s_.length = to_number(l.tokens[1], source_, l.number, "length");
        if (!(s_.length > 0.0)) throw InputError(source_, l.number, "expected a length unit > 0");
      } else if (l.tokens[0] == "angle") {
        if (iequals(l.tokens[1], "deg"))
          s_.angle_in_degrees = true;
        else if (iequals(l.tokens[1], "rad"))
          s_.angle_in_degrees = false;
        else
          throw InputError(source_, l.number,
                           "expected angle deg or rad, found " + show(l.tokens[1]));
      } else {
        throw InputError(source_, l.number,
                         "expected mass, length or angle in :units, found " + show(l.tokens[0]));
      }
    }
  }

  void root() {
    for (; i_ < lines_.size() && !is_section(lines_[i_]); ++i_) {
      const Line& l = lines_[i_];
      const std::string_view kw = l.tokens[0];
      if (kw == "order") {
        s_.root.order.clear();
        for (std::size_t k = 1; k < l.tokens.size(); ++k) {
          AsfDof d{};
          if (!parse_dof(l.tokens[k], d))
            throw InputError(
                source_, l.number,
                "expected TX, TY, TZ, RX, RY or RZ in the root order, found " + show(l.tokens[k]));
          for (const AsfDof e : s_.root.order)
            if (e == d)
              throw InputError(source_, l.number,
                               "root order lists " + show(l.tokens[k]) + " twice");
          s_.root.order.push_back(d);
        }
      } else if (kw == "axis") {
        expect_count(l, 2, source_);
        s_.root.axis_order = parse_axis_order(l.tokens[1], source_, l.number);
      } else if (kw == "position") {
        s_.root.position = parse_vector(l, 1, source_, "position");
      } else if (kw == "orientation") {
        s_.root.orientation_deg = parse_vector(l, 1, source_, "orientation");
      } else {
        throw InputError(
            source_, l.number,
            "expected order, axis, position or orientation in :root, found " + show(kw));
      }
    }
  }

  void bonedata() {
    while (i_ < lines_.size() && !is_section(lines_[i_])) {
      const Line& l = lines_[i_];
      if (l.tokens[0] != "begin" || l.tokens.size() != 1)
        throw InputError(source_, l.number,
                         "expected 'begin' of a bone, found " + show(l.tokens[0]));
      ++i_;
      bone(l.number);
    }
  }

  void bone(std::size_t begin_line) {
    AsfBone b;
    b.line = begin_line;
    bool has_name = false, has_direction = false, has_length = false;
    while (true) {
      if (i_ >= lines_.size() || is_section(lines_[i_]))
        throw InputError(source_, i_ < lines_.size() ? lines_[i_].number : end_line_,
                         "expected 'end' of the bone begun at line " + std::to_string(begin_line));
      const Line& l = lines_[i_++];
      const std::string_view kw = l.tokens[0];
      if (kw == "end") {
        break;
      } else if (kw == "id") {
        expect_count(l, 2, source_);
        b.id = static_cast<int>(to_number(l.tokens[1], source_, l.number, "id"));
      } else if (kw == "name") {
        expect_count(l, 2, source_);
        b.name = std::string(l.tokens[1]);
        if (b.name == "root")
          throw InputError(source_, l.number, "expected a bone name other than 'root'");
        has_name = true;
      } else if (kw == "direction") {
        b.direction = parse_vector(l, 1, source_, "direction");
        has_direction = true;
      } else if (kw == "length") {
        expect_count(l, 2, source_);
        b.length = to_number(l.tokens[1], source_, l.number, "length");
        if (b.length < 0.0) throw InputError(source_, l.number, "expected a length >= 0");
        has_length = true;
      } else if (kw == "axis") {
        expect_count(l, 5, source_);
        b.axis_deg = parse_vector(l, 1, source_, "axis");
        b.axis_order = parse_axis_order(l.tokens[4], source_, l.number);
      } else if (kw == "dof") {
        b.dofs.clear();
        for (std::size_t k = 1; k < l.tokens.size(); ++k) {
          AsfDof d{};
          if (!parse_dof(l.tokens[k], d) || !is_rotation(d))
            throw InputError(source_, l.number,
                             "expected rx, ry or rz in dof (bone translations are not "
                             "supported), found " +
                                 show(l.tokens[k]));
          for (const AsfDof e : b.dofs)
            if (e == d)
              throw InputError(source_, l.number, "dof lists " + show(l.tokens[k]) + " twice");
          b.dofs.push_back(d);
        }
      } else if (kw == "limits") {
        limits(b, l);
      } else if (kw == "bodymass" || kw == "cofmass") {
        // Informative (mass properties); not used.
      } else {
        throw InputError(source_, l.number,
                         "expected id, name, direction, length, axis, dof, limits or end in a "
                         "bone, found " +
                             show(kw));
      }
    }
    if (!has_name) throw InputError(source_, begin_line, "bone has no name");
    if (!has_direction || !has_length)
      throw InputError(source_, begin_line,
                       "bone " + show(b.name) + " needs both direction and length");
    // stableNorm: norm() squares the components, so 1e200 would give inf (and a
    // zero direction) and 1e-170 would give 0 (found by tests/fuzz/asf_fuzz).
    const double n = b.direction.stableNorm();
    if (n > 0.0)
      b.direction /= n;
    else if (b.length > 0.0)
      throw InputError(source_, begin_line, "bone " + show(b.name) + " has a zero direction");
    if (!b.limits.empty() && b.limits.size() != b.dofs.size())
      throw InputError(source_, begin_line,
                       "bone " + show(b.name) + " has " + std::to_string(b.limits.size()) +
                           " limits for " + std::to_string(b.dofs.size()) + " dofs");
    if (index_.contains(b.name))
      throw InputError(source_, begin_line, "bone " + show(b.name) + " is defined twice");
    if (s_.bones.size() >= input_limits().bvh_joints)
      throw InputError(source_, begin_line,
                       "more bones than the limit of " + std::to_string(input_limits().bvh_joints));
    index_.emplace(b.name, static_cast<int>(s_.bones.size()));
    s_.bones.push_back(std::move(b));
  }

  // `limits (lo hi)` and following "(lo hi)" lines: one pair per line, the
  // parentheses may touch the numbers or stand alone.
  void limits(AsfBone& b, const Line& first) {
    auto pair_of = [&](const Line& l, std::size_t from) {
      std::vector<std::string_view> t;
      for (std::size_t k = from; k < l.tokens.size(); ++k) {
        std::string_view s = l.tokens[k];
        if (!s.empty() && s.front() == '(') s.remove_prefix(1);
        if (!s.empty() && s.back() == ')') s.remove_suffix(1);
        if (!s.empty()) t.push_back(s);
      }
      if (t.size() != 2 || l.tokens[from].front() != '(' || l.tokens.back().back() != ')')
        throw InputError(source_, l.number, "expected a limit pair '(lo hi)'");
      b.limits.push_back({to_bound(t[0], source_, l.number), to_bound(t[1], source_, l.number)});
    };
    b.limits.clear();
    if (first.tokens.size() < 2) throw InputError(source_, first.number, "expected '(lo hi)'");
    pair_of(first, 1);
    while (i_ < lines_.size() && lines_[i_].tokens[0].front() == '(') pair_of(lines_[i_++], 0);
  }

  void hierarchy() {
    if (i_ >= lines_.size() || lines_[i_].tokens[0] != "begin")
      throw InputError(source_, i_ < lines_.size() ? lines_[i_].number : end_line_,
                       "expected 'begin' after :hierarchy");
    ++i_;
    while (true) {
      if (i_ >= lines_.size() || is_section(lines_[i_]))
        throw InputError(source_, i_ < lines_.size() ? lines_[i_].number : end_line_,
                         "expected 'end' of :hierarchy");
      const Line& l = lines_[i_++];
      if (l.tokens[0] == "end") break;
      hierarchy_lines_.push_back(l);
    }
  }

  // Resolves :hierarchy into parents: every named bone must be defined, each
  // bone has one parent, there is no cycle and every bone hangs off the root.
  void link() {
    constexpr int kUnset = -2;
    std::vector<int> parent(s_.bones.size(), kUnset);
    std::vector<std::size_t> parent_line(s_.bones.size(), 0);
    auto bone_at = [&](std::string_view name, std::size_t line) {
      const auto it = index_.find(std::string(name));
      if (it == index_.end())
        throw InputError(source_, line,
                         "bone " + show(name) + " is in :hierarchy but not defined in :bonedata");
      return it->second;
    };
    for (const Line& l : hierarchy_lines_) {
      if (l.tokens.size() < 2)
        throw InputError(source_, l.number, "expected a parent and its children");
      const int p = l.tokens[0] == "root" ? -1 : bone_at(l.tokens[0], l.number);
      for (std::size_t k = 1; k < l.tokens.size(); ++k) {
        if (l.tokens[k] == "root")
          throw InputError(source_, l.number, "cycle: 'root' cannot be a child");
        const int c = bone_at(l.tokens[k], l.number);
        if (c == p)
          throw InputError(source_, l.number, "cycle: " + show(l.tokens[k]) + " is its own parent");
        if (parent[c] != kUnset)
          throw InputError(source_, l.number,
                           "bone " + show(l.tokens[k]) + " has a second parent (first at line " +
                               std::to_string(parent_line[c]) + ")");
        parent[c] = p;
        parent_line[c] = l.number;
        if (p == -1) s_.root_children.push_back(c);
      }
    }
    const std::size_t n = s_.bones.size();
    for (std::size_t b = 0; b < n; ++b) {
      int at = static_cast<int>(b);
      std::size_t steps = 0;
      while (at >= 0 && parent[at] != kUnset && steps <= n) {
        at = parent[at];
        ++steps;
      }
      if (steps > n)
        throw InputError(source_, parent_line[b],
                         "cycle in :hierarchy through bone " + show(s_.bones[b].name));
      if (at != -1)
        throw InputError(source_, s_.bones[b].line,
                         "bone " + show(s_.bones[b].name) +
                             " is not connected to the root in :hierarchy (line " +
                             std::to_string(hierarchy_line_) + ")");
      s_.bones[b].parent = parent[b];
    }
  }

  void to_degrees() {
    s_.root.orientation_deg *= kDegPerRad;
    for (AsfBone& b : s_.bones) {
      b.axis_deg *= kDegPerRad;
      for (std::size_t k = 0; k < b.limits.size(); ++k) {
        b.limits[k].lo *= kDegPerRad;
        b.limits[k].hi *= kDegPerRad;
      }
    }
  }

  const std::string& source_;
  std::vector<Line> lines_;
  std::vector<Line> hierarchy_lines_;
  std::size_t hierarchy_line_ = 0;
  std::size_t end_line_ = 1;
  std::size_t i_ = 0;
  AsfSkeleton s_;
  std::unordered_map<std::string, int> index_;
};

bool is_frame_number(const Line& l, long& out) {
  if (l.tokens.size() != 1) return false;
  const std::string_view t = l.tokens[0];
  const auto [p, ec] = std::from_chars(t.data(), t.data() + t.size(), out);
  return ec == std::errc() && p == t.data() + t.size();
}

std::string dof_list(const std::vector<AsfDof>& dofs) {
  static constexpr const char* kNames[] = {"tx", "ty", "tz", "rx", "ry", "rz"};
  std::string s;
  for (const AsfDof d : dofs) {
    if (!s.empty()) s += ' ';
    s += kNames[static_cast<int>(d)];
  }
  return s.empty() ? "none" : s;
}

FileBytes read_text(const std::filesystem::path& path) {
  return read_input_file(path, input_limits().bvh_bytes);
}

}  // namespace

int AsfSkeleton::find_bone(std::string_view bone_name) const {
  for (std::size_t i = 0; i < bones.size(); ++i)
    if (bones[i].name == bone_name) return static_cast<int>(i);
  return -1;
}

AsfSkeleton parse_asf(std::string_view text, const std::string& source) {
  return AsfParser(text, source).run();
}

// ---------------------------------------------------------------------------
// AMC

AmcMotion parse_amc(std::string_view text, const std::string& source, const AsfSkeleton& skeleton) {
  AmcMotion m;
  m.source = source;
  std::unordered_map<std::string_view, int> index;  // bone index, -1 for the root
  index.emplace("root", -1);
  std::size_t column = skeleton.root.order.size();
  for (std::size_t b = 0; b < skeleton.bones.size(); ++b) {
    index.emplace(skeleton.bones[b].name, static_cast<int>(b));
    m.bone_columns.push_back(column);
    column += skeleton.bones[b].dofs.size();
  }
  m.value_count = column;

  // Bone lines come in the same order in every frame, so the bone that
  // followed the previous line's bone last time is tried first (one compare)
  // before the hash lookup. next_bone[0]: after a frame number; [b + 2]: after
  // bone b (root = -1); kNoHint when not seen yet.
  constexpr int kNoHint = -2;
  std::vector<int> next_bone(skeleton.bones.size() + 2, kNoHint);
  std::size_t after = 0;
  auto bone_name = [&](int b) -> std::string_view {
    return b < 0 ? std::string_view("root") : std::string_view(skeleton.bones[b].name);
  };

  LineReader reader(text, source);
  Line l;
  bool in_frames = false;
  long expected = 0;
  std::vector<char> seen(skeleton.bones.size() + 1);
  while (reader.next(l)) {
    const std::string_view first = l.tokens[0];
    if (first[0] == ':') {
      if (in_frames)
        throw InputError(source, l.number,
                         "expected a bone line or a frame number, found " + show(first));
      if (l.tokens.size() != 1)
        throw InputError(source, l.number, "expected nothing after " + show(first));
      if (iequals(first, ":FULLY-SPECIFIED")) continue;
      if (iequals(first, ":DEGREES")) {
        m.file_in_degrees = true;
      } else if (iequals(first, ":RADIANS")) {
        m.file_in_degrees = false;
      } else {
        throw InputError(source, l.number,
                         "expected :FULLY-SPECIFIED, :DEGREES or :RADIANS, found " + show(first));
      }
      continue;
    }
    long number = 0;
    if (is_frame_number(l, number)) {
      if (!in_frames) {
        m.first_frame_number = number;
        expected = number;
        in_frames = true;
      } else if (number != expected) {
        throw InputError(source, l.number,
                         "expected frame number " + std::to_string(expected) + ", found " +
                             show(first) + " (frames must be consecutive)");
      }
      ++expected;
      ++m.frame_count;
      m.values.resize(m.values.size() + m.value_count, 0.0);
      std::fill(seen.begin(), seen.end(), 0);
      after = 0;
      continue;
    }
    if (!in_frames)
      throw InputError(source, l.number,
                       "expected a frame number before bone values, found " + show(first));
    int b = next_bone[after];
    if (b == kNoHint || bone_name(b) != first) {
      const auto it = index.find(first);
      if (it == index.end())
        throw InputError(source, l.number,
                         "bone " + show(first) + " is not in the skeleton " +
                             show(skeleton.source) + " (an ASF that does not fit this AMC?)");
      b = it->second;
      next_bone[after] = b;
    }
    after = static_cast<std::size_t>(b + 2);
    const std::vector<AsfDof>& dofs = b < 0 ? skeleton.root.order : skeleton.bones[b].dofs;
    if (l.tokens.size() - 1 != dofs.size())
      throw InputError(source, l.number,
                       "bone " + show(first) + " has dofs (" + dof_list(dofs) +
                           ") in the skeleton: expected " + std::to_string(dofs.size()) +
                           " values, found " + std::to_string(l.tokens.size() - 1));
    if (seen[static_cast<std::size_t>(b + 1)])
      throw InputError(
          source, l.number,
          "bone " + show(first) + " appears twice in frame " + std::to_string(expected - 1));
    seen[static_cast<std::size_t>(b + 1)] = 1;
    double* out = m.values.data() + (m.frame_count - 1) * m.value_count +
                  (b < 0 ? 0 : m.bone_columns[static_cast<std::size_t>(b)]);
    for (std::size_t k = 0; k < dofs.size(); ++k) {
      double v = to_number(l.tokens[k + 1], source, l.number, "a dof value");
      if (!m.file_in_degrees && is_rotation(dofs[k])) v *= kDegPerRad;
      out[k] = v;
    }
  }
  return m;
}

// ---------------------------------------------------------------------------
// Conversion

// Joints depth-first from the root (joint 0); each bone's rotation
// L_b = C_b * M_b * C_b^-1 becomes Euler "Z Y X" degrees (asf_amc.hpp).
RawClip asf_amc_to_raw_clip(const AsfSkeleton& skeleton, const AmcMotion& motion,
                            double frame_time_s) {
  if (!(frame_time_s > 0.0) || !std::isfinite(frame_time_s))
    throw std::invalid_argument("asf_amc_to_raw_clip: frame_time_s must be > 0");
  if (motion.bone_columns.size() != skeleton.bones.size())
    throw std::invalid_argument("asf_amc_to_raw_clip: motion was not parsed for this skeleton");
  static constexpr Channel kRotations[] = {Channel::Zrotation, Channel::Yrotation,
                                           Channel::Xrotation};

  RawClip clip;
  clip.source = motion.source;
  clip.frame_time_s = frame_time_s;
  clip.frame_count = motion.frame_count;

  RawJoint root;
  root.name = "root";
  root.offset = skeleton.root.position;
  root.channels = {Channel::Xposition, Channel::Yposition, Channel::Zposition,
                   kRotations[0],      kRotations[1],      kRotations[2]};
  clip.joints.push_back(root);
  std::size_t columns = 6;

  std::vector<std::vector<int>> children(skeleton.bones.size());
  for (std::size_t b = 0; b < skeleton.bones.size(); ++b)
    if (skeleton.bones[b].parent >= 0)
      children[static_cast<std::size_t>(skeleton.bones[b].parent)].push_back(static_cast<int>(b));
  std::vector<int> joint_bones;  // bone of each joint after the root
  std::vector<int> joint_of(skeleton.bones.size(), 0);
  std::vector<int> stack(skeleton.root_children.rbegin(), skeleton.root_children.rend());
  while (!stack.empty()) {
    const int b = stack.back();
    stack.pop_back();
    const AsfBone& bone = skeleton.bones[static_cast<std::size_t>(b)];
    RawJoint j;
    j.name = bone.name;
    j.parent = bone.parent < 0 ? 0 : joint_of[static_cast<std::size_t>(bone.parent)];
    if (bone.parent >= 0) {
      const AsfBone& p = skeleton.bones[static_cast<std::size_t>(bone.parent)];
      j.offset = p.direction * p.length;
    }
    if (!bone.dofs.empty()) {
      j.channels.assign(std::begin(kRotations), std::end(kRotations));
      j.first_column = columns;
      columns += 3;
    }
    if (children[static_cast<std::size_t>(b)].empty()) {
      j.has_end_site = true;
      j.end_site = bone.direction * bone.length;
    }
    joint_of[static_cast<std::size_t>(b)] = static_cast<int>(clip.joints.size());
    clip.joints.push_back(std::move(j));
    joint_bones.push_back(b);
    const auto& c = children[static_cast<std::size_t>(b)];
    stack.insert(stack.end(), c.rbegin(), c.rend());
  }
  clip.channel_count = columns;
  clip.values.assign(clip.frame_count * columns, 0.0);

  // C and C^-1 per bone, once.
  std::vector<Eigen::Quaterniond> axes(skeleton.bones.size());
  for (std::size_t b = 0; b < skeleton.bones.size(); ++b)
    axes[b] = ordered_rotation(skeleton.bones[b].axis_order, skeleton.bones[b].axis_deg);
  const Eigen::Quaterniond root_axis =
      ordered_rotation(skeleton.root.axis_order, skeleton.root.orientation_deg);

  for (std::size_t f = 0; f < clip.frame_count; ++f) {
    const double* in = motion.frame(f);
    double* out = clip.values.data() + f * columns;
    Eigen::Vector3d t = skeleton.root.position;
    Eigen::Vector3d r = Eigen::Vector3d::Zero();
    for (std::size_t k = 0; k < skeleton.root.order.size(); ++k) {
      const AsfDof d = skeleton.root.order[k];
      (is_rotation(d) ? r : t)[dof_axis(d)] += in[k];
    }
    const Eigen::Quaterniond lr =
        root_axis * ordered_rotation(skeleton.root.axis_order, r) * root_axis.conjugate();
    const Eigen::Vector3d re = quaternion_to_euler_zyx(lr);
    for (int a = 0; a < 3; ++a) {
      out[a] = t[a];
      out[3 + a] = re[a];
    }
    for (std::size_t j = 1; j < clip.joints.size(); ++j) {
      const RawJoint& joint = clip.joints[j];
      if (joint.channels.empty()) continue;
      const auto b = static_cast<std::size_t>(joint_bones[j - 1]);
      const AsfBone& bone = skeleton.bones[b];
      const double* values = in + motion.bone_columns[b];
      // Values bit for bit those of the previous frame (7% of CMU's bone
      // lines: clavicles, fingers) give the previous frame's angles.
      if (f > 0 && std::memcmp(values, values - motion.value_count,
                               bone.dofs.size() * sizeof(double)) == 0) {
        std::memcpy(out + joint.first_column, out + joint.first_column - columns,
                    3 * sizeof(double));
        continue;
      }
      Eigen::Vector3d deg = Eigen::Vector3d::Zero();
      for (std::size_t k = 0; k < bone.dofs.size(); ++k) deg[dof_axis(bone.dofs[k])] = values[k];
      const Eigen::Quaterniond l =
          axes[b] * ordered_rotation(bone.axis_order, deg) * axes[b].conjugate();
      const Eigen::Vector3d e = quaternion_to_euler_zyx(l);
      for (int a = 0; a < 3; ++a) out[joint.first_column + static_cast<std::size_t>(a)] = e[a];
    }
  }
  return clip;
}

AsfSkeleton read_asf_file(const std::filesystem::path& path) {
  return parse_asf(read_text(path).view(), path.string());
}

AmcMotion read_amc_file(const std::filesystem::path& path, const AsfSkeleton& skeleton) {
  return parse_amc(read_text(path).view(), path.string(), skeleton);
}

RawClip read_asf_amc_files(const std::filesystem::path& asf, const std::filesystem::path& amc,
                           double frame_time_s) {
  const AsfSkeleton skeleton = read_asf_file(asf);
  return asf_amc_to_raw_clip(skeleton, read_amc_file(amc, skeleton), frame_time_s);
}

}  // namespace mocap
