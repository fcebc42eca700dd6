#pragma once
// BVH reading and writing.
//
// Reader: hand-written tokenizer over the whole text (std::from_chars, no
// regex, no per-line allocation). Accepts every real-world variation: any of
// the 6 Euler orders per joint, 0/3/6 channels per joint (subsets too),
// position channels on any joint, End Sites, zero-length joints, tabs, CRLF,
// repeated blanks, trailing whitespace, scientific notation, numbers like
// ".0083" or "+1", several ROOTs. "Frame Time" is read, never assumed.
// Malformed input throws InputError naming the file, the 1-based line and what
// was expected; memory is bounded by the text size, never by a lying
// "Frames:" count.
//
// Writer: root with OFFSET 0 0 0 and 6 channels (Xposition Yposition Zposition
// + rotations), 3 rotation channels on every other joint, in the order given.
// Blender and three.js load it identically.
#include <filesystem>
#include <string>
#include <string_view>

#include "mocap/common/io/raw_clip.hpp"

namespace mocap {

/// Parses BVH text. `source` names the text in error messages.
RawClip parse_bvh(std::string_view text, const std::string& source);

/// The hierarchy section of a BVH text, as parsed (parse_bvh_window).
struct BvhHierarchy {
  /// The text's bytes from its start through the MOTION keyword.
  std::string prefix;
  /// Line (1-based) the text is on right after MOTION.
  std::size_t motion_line = 1;
  /// Joints and channel_count; no frames, empty source.
  RawClip clip;
  /// True when `text` begins with `prefix` and a blank, a newline or the end
  /// follows it: its hierarchy then parses to `clip`, byte for byte the same
  /// tokens. False for an empty prefix.
  bool heads(std::string_view text) const;
};

/// Frames [first_frame, first_frame + clip.frame_count) of a BVH text.
struct BvhWindow {
  RawClip clip;  // the header, and only the window's frames (clip.frame_count of them)
  std::size_t first_frame = 0;
  std::size_t file_frame_count = 0;  // "Frames:" of the text
};

/// Parses the hierarchy and the frames [first, first + count) (clamped to the
/// file) of BVH text, with exactly parse_bvh's values for them. The frame
/// lines before the window are skipped to their newline without being read
/// and those after it are not looked at, so errors there go unnoticed: meant
/// for text known to parse (e.g. a file whose bytes hash to an index's
/// content hash). Errors in what it reads throw as parse_bvh does.
/// With `hierarchy` given, it also receives the text's hierarchy, for texts
/// that begin with the same bytes (the overload below).
BvhWindow parse_bvh_window(std::string_view text, const std::string& source, std::size_t first,
                           std::size_t count, BvhHierarchy* hierarchy = nullptr);

/// parse_bvh_window of a text that `known` heads (known.heads(text), else
/// std::invalid_argument): the hierarchy is not parsed again, the result is
/// the same (line numbers in messages included). A library's files of one
/// skeleton usually share their hierarchy bytes, so a reader of many of them
/// parses it once.
BvhWindow parse_bvh_window(std::string_view text, const std::string& source,
                           const BvhHierarchy& known, std::size_t first, std::size_t count);

/// Reads and parses a file; unreadable files throw InputError(path, 0, reason).
RawClip read_bvh_file(const std::filesystem::path& path);

/// BVH text for a clip. Every joint's channels are written as they are in
/// `clip` (so a parsed clip round-trips exactly to print precision).
/// `precision`: significant digits for numbers (default keeps 1e-6 relative).
/// A clip of a broken shape (no joint, a parent after its child, channels past
/// the frame row or more than 6 on a joint, values not frame_count x
/// channel_count) throws std::invalid_argument; a joint name BVH cannot hold
/// (empty, blank at either end, braces, line breaks, binary bytes), a
/// non-finite value or a frame time that is not positive and finite throws
/// InputError(clip.source, 0, ...).
std::string write_bvh(const RawClip& clip, int precision = 9);

/// Writes to a file (through a temporary file + rename); throws InputError on failure.
void write_bvh_file(const RawClip& clip, const std::filesystem::path& path, int precision = 9);

}  // namespace mocap

namespace mocap {

/// The export layout that Blender and three.js load identically: the root gets
/// OFFSET 0 0 0 and 6 channels (positions then its rotations, its OFFSET folded
/// into the position values); every other joint keeps only its 3 rotation
/// channels (missing rotation axes are added with value 0, in ZXY order when
/// the joint had none), its position channels folded into OFFSET. Non-root
/// position channels that vary over the clip by more than `tolerance` (file
/// units) cannot be folded and throw InputError, except for one joint per tree
/// whose ancestors form a bare chain up to the root (each has only this one
/// child and no End Site; Bandai Namco's static joint_Root above a moving
/// Hips): its motion moves to the root's position values and it keeps its
/// frame-0 translation as OFFSET. World positions of every joint and End Site
/// are kept exactly, except those of that chain's ancestors (which move with
/// the root). Channels keep their values; a root without position channels
/// gets its OFFSET as position values. A clip of a broken shape throws as in
/// write_bvh.
RawClip to_export_layout(const RawClip& clip, double tolerance = 1e-4);

}  // namespace mocap
