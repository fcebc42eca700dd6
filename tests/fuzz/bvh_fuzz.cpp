// libFuzzer target for the BVH reader and writer.
//
// Any input must either parse or throw mocap::InputError (never crash, hang or
// allocate beyond the text size). When it parses, write_bvh at full precision
// and parse again must give back the same clip bit for bit, and
// to_export_layout must either throw InputError or give a clip that writes
// and reads back.
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <string_view>

#include "mocap/common/io/bvh.hpp"
#include "mocap/common/util/error.hpp"

namespace {

[[noreturn]] void fail(const char* what) {
  std::fprintf(stderr, "bvh_fuzz: %s\n", what);
  std::abort();
}

bool same_clip(const mocap::RawClip& a, const mocap::RawClip& b) {
  if (a.joints.size() != b.joints.size() || a.channel_count != b.channel_count ||
      a.frame_count != b.frame_count || a.frame_time_s != b.frame_time_s || a.values != b.values)
    return false;
  for (std::size_t j = 0; j < a.joints.size(); ++j) {
    const mocap::RawJoint& x = a.joints[j];
    const mocap::RawJoint& y = b.joints[j];
    if (x.name != y.name || x.parent != y.parent || x.channels != y.channels ||
        x.first_column != y.first_column || x.offset != y.offset ||
        x.has_end_site != y.has_end_site || (x.has_end_site && x.end_site != y.end_site))
      return false;
  }
  return true;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  mocap::RawClip clip;
  try {
    clip = mocap::parse_bvh(text, "fuzz");
  } catch (const mocap::InputError&) {
    return 0;
  }
  if (clip.values.size() != clip.frame_count * clip.channel_count)
    fail("values size != frames x channels");
  if (clip.values.size() > size) fail("more values than bytes of text");
  std::string written;
  try {
    written = mocap::write_bvh(clip, 17);
  } catch (const mocap::InputError& e) {
    // Names the reader accepts but the writer refuses are a reader/writer mismatch.
    std::fprintf(stderr, "%s\n", e.what());
    fail("write_bvh refused a parsed clip");
  }
  mocap::RawClip again;
  try {
    again = mocap::parse_bvh(written, "fuzz-written");
  } catch (const mocap::InputError& e) {
    std::fprintf(stderr, "%s\n--- written ---\n%s\n", e.what(), written.c_str());
    fail("written BVH does not parse");
  }
  if (!same_clip(clip, again)) fail("parse(write(parse(x))) != parse(x)");
  try {
    const mocap::RawClip exported = mocap::to_export_layout(clip);
    (void)mocap::parse_bvh(mocap::write_bvh(exported, 17), "fuzz-export");
  } catch (const mocap::InputError&) {
  }
  return 0;
}
