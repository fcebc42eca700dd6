// Internal to mocap_common: the checksum of an index dataset as the writer
// stores it (attribute checksum_xxh64), for verify and for Index::open's
// check of the small tables.
#pragma once

#include <cstdint>

#include "mocap/common/io/hdf5.hpp"

namespace mocap {

/// What a streaming pass over a dataset found besides its checksum.
struct ValueFindings {
  std::uint64_t first_non_finite = UINT64_MAX;      // element index
  std::uint64_t first_bad_quaternion = UINT64_MAX;  // quaternion index (when checked)
};

/// XXH64 of a dataset's values in their stored type (strings: bytes + NUL
/// each), read in blocks of rows (bounded memory). Float values are checked
/// to be finite; with `quaternions`, rows of 4 values to be unit with w >= 0.
std::uint64_t dataset_checksum(const h5::Dataset& d, ValueFindings* findings = nullptr,
                               bool quaternions = false);

/// Throws InputError(file, 0, "PATH: checksum mismatch (the index is damaged)")
/// for every dataset directly in `g` (not in its subgroups) whose values do
/// not hash to its checksum_xxh64 attribute.
void check_group_checksums(const h5::Group& g);

}  // namespace mocap
