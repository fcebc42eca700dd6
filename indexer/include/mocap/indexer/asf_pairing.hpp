#pragma once
// ASF/AMC clips in the indexer: which ASF skeleton an AMC take is read with,
// and reading a capture file (BVH, or AMC with its ASF) into a RawClip
// (docs/asf-amc.md "Pairing in the indexer").
//
// The ASF of `X.amc` is, the first rule that gives one:
//   1. `--asf FILE` when given (an absent FILE is an error, not a fall-through);
//   2. the only `.asf` file of the AMC's folder;
//   3. `NN.asf` for `NN_MM.amc` (CMU's subject_take names: the stem up to its
//      last '_');
//   4. `X.asf`;
//   5. the ASF whose stem is a prefix of X (charleston.asf for
//      charleston1.amc); when several are, the longest.
// Names compare exactly (case-sensitive); the extension `.asf` / `.amc` in
// any case. No rule matching is an error naming the AMC and the rules tried.
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "mocap/common/io/raw_clip.hpp"

namespace mocap {

/// True for a `.amc` / `.asf` name (any case).
bool has_amc_extension(const std::filesystem::path& p);
bool has_asf_extension(const std::filesystem::path& p);

/// The outcome of pairing: `asf` (empty when none) or `error` (the reason).
struct AsfPairing {
  std::filesystem::path asf;
  std::string error;
};

/// The rules above on given names: `folder_asf_names` are the file names
/// (not paths) of the `.asf` files in the AMC's folder, any order.
/// `asf_option` is taken as given (its existence is not checked here).
/// An empty `amc` or one without the `.amc` extension is an error.
AsfPairing pair_asf_by_name(const std::filesystem::path& amc,
                            const std::optional<std::filesystem::path>& asf_option,
                            const std::vector<std::string>& folder_asf_names);

/// The rules on the file system: lists the AMC's folder (regular files and
/// links to them) and checks that `asf_option`, when given, is a file.
AsfPairing pair_asf(const std::filesystem::path& amc,
                    const std::optional<std::filesystem::path>& asf_option);

/// How AMC takes are read: the ASF (nullopt = the rules) and the frame time
/// (AMC has none; CMU captures at 120 fps).
struct AmcReadOptions {
  std::optional<std::filesystem::path> asf;
  double frame_time_s = 1.0 / 120.0;
};

/// A capture file read for a tool: the clip, and for an AMC take its ASF and
/// the ASF's metres per file unit (AsfSkeleton::metres_per_unit).
struct CaptureFile {
  RawClip clip;
  std::filesystem::path asf;              // empty for BVH
  std::optional<double> metres_per_unit;  // nullopt for BVH
};

/// Reads a BVH file, or an AMC file with its paired ASF. Throws InputError
/// naming the file for a bad file or an AMC without an ASF.
CaptureFile read_capture_file(const std::filesystem::path& path, const AmcReadOptions& amc);

/// The clip unit name of an ASF/AMC clip in an index and in inspect
/// (docs/units.md): its scale is the ASF's, not one of the --unit units.
inline constexpr const char* kAsfUnitName = "asf";

}  // namespace mocap
