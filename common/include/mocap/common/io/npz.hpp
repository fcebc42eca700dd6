#pragma once
// NumPy's .npy and .npz formats, written (and read back) without a library.
//
// .npy (format version 1.0): the magic "\x93NUMPY", the version bytes 1 0, a
// little-endian uint16 header length, then an ASCII Python dict literal
//   {'descr': '<f8', 'fortran_order': False, 'shape': (F, J, 3), }
// padded with blanks and a final '\n' so that the data starts at a multiple
// of 64 bytes; then the array's bytes, C order. .npz: a zip archive of
// NAME.npy members. Ours are "stored" (method 0, no compression; numpy.load
// reads them), each with its CRC-32, and without the zip64 extension: an
// archive of 4 GiB or more, or of more than 65,535 members, is refused.
// Members are dated 1980-01-01 00:00 (the zip epoch), so the same arrays give
// the same bytes.
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace mocap {

/// CRC-32 of zip, gzip and PNG (ISO-HDLC: reflected polynomial 0xEDB88320,
/// initial and final XOR 0xFFFFFFFF). `crc` continues an earlier value
/// (crc32(b, crc32(a)) == crc32(a + b)); crc32("123456789") == 0xCBF43926.
std::uint32_t crc32(std::string_view bytes, std::uint32_t crc = 0);

/// One array as .npy holds it: `descr` is numpy's type string ("<f8": little-
/// endian float64, "<i4": int32, "<U12": UTF-32 strings of up to 12 code
/// points), `shape` its dimensions (empty: a 0-d scalar), `data` the
/// elements' bytes in C order (product of shape x item size bytes).
struct NpyArray {
  std::string descr;
  std::vector<std::size_t> shape;
  std::string data;
};

/// float64 array of `shape` (values.size() must be the product of shape:
/// std::invalid_argument otherwise), little-endian whatever the host.
NpyArray npy_float64(std::vector<std::size_t> shape, const std::vector<double>& values);
/// int32 1-d array, little-endian.
NpyArray npy_int32(const std::vector<std::int32_t>& values);
/// 1-d array of strings ("<U" + the longest length in code points, at least
/// 1). The strings are UTF-8; a byte that does not start a valid UTF-8
/// sequence is taken as the Latin-1 character of that byte.
NpyArray npy_strings(const std::vector<std::string>& values);

/// The .npy file of an array (format version 1.0). std::invalid_argument when
/// data.size() does not match the shape and the descr's item size.
std::string npy_bytes(const NpyArray& array);
/// Parses a .npy file of version 1.0 or 2.0 written in C order. Anything else
/// (bad magic, a header that is not the dict above, fortran_order True, a
/// data size that does not match) throws InputError(source, 0, ...).
NpyArray parse_npy(std::string_view bytes, const std::string& source);

/// A zip archive of `members` (name, bytes), stored, in the order given.
/// Throws InputError(source, 0, ...) for an empty or duplicate name, or when
/// the archive would need zip64 (see the top of this file).
std::string zip_stored(const std::vector<std::pair<std::string, std::string>>& members,
                       const std::string& source);
/// The members of a zip archive written by zip_stored (stored members only;
/// each one's CRC-32 and sizes are checked against its central directory
/// entry). Anything else throws InputError(source, 0, ...).
std::vector<std::pair<std::string, std::string>> read_zip_stored(std::string_view bytes,
                                                                 const std::string& source);

}  // namespace mocap
