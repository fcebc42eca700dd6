// NumPy's .npy and .npz formats (npz.hpp): the array header, stored zip
// members and their CRC-32.
#include "mocap/common/io/npz.hpp"

#include <algorithm>
#include <array>
#include <charconv>
#include <cstring>
#include <limits>
#include <set>
#include <stdexcept>

#include "mocap/common/util/error.hpp"

namespace mocap {

namespace {

// The CRC-32 table of the reflected polynomial 0xEDB88320, one entry per byte.
std::array<std::uint32_t, 256> make_crc_table() {
  std::array<std::uint32_t, 256> table{};
  for (std::uint32_t i = 0; i < 256; ++i) {
    std::uint32_t c = i;
    for (int k = 0; k < 8; ++k) c = (c & 1U) ? 0xEDB88320U ^ (c >> 1) : c >> 1;
    table[i] = c;
  }
  return table;
}

// Little-endian bytes of an unsigned integer of `n` bytes.
void put_le(std::string& out, std::uint64_t v, int n) {
  for (int k = 0; k < n; ++k) out.push_back(static_cast<char>((v >> (8 * k)) & 0xFFU));
}

std::uint64_t get_le(std::string_view bytes, std::size_t at, int n) {
  std::uint64_t v = 0;
  for (int k = 0; k < n; ++k)
    v |= static_cast<std::uint64_t>(
             static_cast<unsigned char>(bytes[at + static_cast<std::size_t>(k)]))
         << (8 * k);
  return v;
}

std::size_t element_count(const std::vector<std::size_t>& shape) {
  std::size_t n = 1;
  for (std::size_t d : shape) n *= d;
  return n;
}

// Bytes per element of a descr ("<f8" 8, "<i4" 4, "<U12" 48); 0 when unknown.
std::size_t item_size(const std::string& descr) {
  if (descr.size() < 3 || std::string_view("<>|=").find(descr[0]) == std::string_view::npos)
    return 0;
  std::size_t n = 0;
  const char* first = descr.data() + 2;
  const char* last = descr.data() + descr.size();
  const auto r = std::from_chars(first, last, n);
  if (r.ec != std::errc() || r.ptr != last) return 0;
  return descr[1] == 'U' ? 4 * n : n;
}

// The next code point of UTF-8 text at `i` (advanced past it); a byte that
// starts no valid sequence is its Latin-1 character.
char32_t next_code_point(const std::string& s, std::size_t& i) {
  const auto byte = [&s](std::size_t k) { return static_cast<unsigned char>(s[k]); };
  const unsigned char b = byte(i);
  const int extra = b >= 0xF0 && b < 0xF5 ? 3 : b >= 0xE0 ? 2 : b >= 0xC2 && b < 0xE0 ? 1 : 0;
  if (b >= 0x80 && extra > 0 && i + static_cast<std::size_t>(extra) < s.size()) {
    char32_t c = b & (0x3FU >> extra);
    bool ok = true;
    for (int k = 1; k <= extra && ok; ++k) {
      const unsigned char t = byte(i + static_cast<std::size_t>(k));
      ok = (t & 0xC0U) == 0x80U;
      c = (c << 6) | (t & 0x3FU);
    }
    const char32_t least[4] = {0, 0x80, 0x800, 0x10000};
    if (ok && c >= least[extra] && c <= 0x10FFFF && (c < 0xD800 || c > 0xDFFF)) {
      i += static_cast<std::size_t>(extra) + 1;
      return c;
    }
  }
  ++i;
  return b;
}

std::u32string utf32(const std::string& s) {
  std::u32string out;
  for (std::size_t i = 0; i < s.size();) out.push_back(next_code_point(s, i));
  return out;
}

std::string shape_text(const std::vector<std::size_t>& shape) {
  std::string t = "(";
  for (std::size_t k = 0; k < shape.size(); ++k) {
    if (k > 0) t += ", ";
    t += std::to_string(shape[k]);
  }
  return t + (shape.size() == 1 ? ",)" : ")");
}

}  // namespace

std::uint32_t crc32(std::string_view bytes, std::uint32_t crc) {
  static const std::array<std::uint32_t, 256> table = make_crc_table();
  std::uint32_t c = crc ^ 0xFFFFFFFFU;
  for (const char ch : bytes) c = table[(c ^ static_cast<unsigned char>(ch)) & 0xFFU] ^ (c >> 8);
  return c ^ 0xFFFFFFFFU;
}

NpyArray npy_float64(std::vector<std::size_t> shape, const std::vector<double>& values) {
  if (element_count(shape) != values.size())
    throw std::invalid_argument("npy_float64: " + std::to_string(values.size()) +
                                " values for shape " + shape_text(shape));
  NpyArray a{"<f8", std::move(shape), {}};
  a.data.reserve(values.size() * 8);
  for (const double v : values) {
    std::uint64_t bits = 0;
    std::memcpy(&bits, &v, sizeof bits);
    put_le(a.data, bits, 8);
  }
  return a;
}

NpyArray npy_int32(const std::vector<std::int32_t>& values) {
  NpyArray a{"<i4", {values.size()}, {}};
  for (const std::int32_t v : values) put_le(a.data, static_cast<std::uint32_t>(v), 4);
  return a;
}

NpyArray npy_strings(const std::vector<std::string>& values) {
  std::vector<std::u32string> wide;
  std::size_t width = 1;
  for (const std::string& s : values) {
    wide.push_back(utf32(s));
    width = std::max(width, wide.back().size());
  }
  NpyArray a{"<U" + std::to_string(width), {values.size()}, {}};
  for (const std::u32string& w : wide)
    for (std::size_t k = 0; k < width; ++k) put_le(a.data, k < w.size() ? w[k] : 0, 4);
  return a;
}

std::string npy_bytes(const NpyArray& array) {
  const std::size_t item = item_size(array.descr);
  if (item == 0 || element_count(array.shape) * item != array.data.size())
    throw std::invalid_argument("npy_bytes: " + std::to_string(array.data.size()) +
                                " bytes for descr '" + array.descr + "' and shape " +
                                shape_text(array.shape));
  std::string header = "{'descr': '" + array.descr +
                       "', 'fortran_order': False, 'shape': " + shape_text(array.shape) + ", }";
  // Magic (6) + version (2) + length (2) + header + '\n': a multiple of 64.
  const std::size_t unpadded = 10 + header.size() + 1;
  header.append((64 - unpadded % 64) % 64, ' ');
  header.push_back('\n');
  std::string out("\x93NUMPY\x01\x00", 8);
  put_le(out, header.size(), 2);
  out += header;
  out += array.data;
  return out;
}

namespace {

// The value text of key `key` in a .npy header dict: what follows "'key':"
// up to the next top-level comma (a parenthesised shape counts as one).
std::string header_value(const std::string& header, const std::string& key,
                         const std::string& source) {
  const std::size_t at = header.find("'" + key + "':");
  if (at == std::string::npos)
    throw InputError(source, 0, "npy header has no '" + key + "': " + header);
  std::size_t i = at + key.size() + 3;
  while (i < header.size() && header[i] == ' ') ++i;
  const std::size_t end =
      header[i] == '(' ? header.find(')', i) + 1 : header.find_first_of(",}", i);
  if (end == std::string::npos || end == 0)
    throw InputError(source, 0, "npy header's '" + key + "' has no end: " + header);
  return header.substr(i, end - i);
}

std::vector<std::size_t> parse_shape(const std::string& text, const std::string& source) {
  std::vector<std::size_t> shape;
  std::size_t i = 1;
  while (i + 1 < text.size()) {
    while (i < text.size() && (text[i] == ' ' || text[i] == ',')) ++i;
    if (i + 1 >= text.size()) break;
    std::size_t d = 0;
    const auto r = std::from_chars(text.data() + i, text.data() + text.size() - 1, d);
    if (r.ec != std::errc()) throw InputError(source, 0, "npy shape is not integers: " + text);
    shape.push_back(d);
    i = static_cast<std::size_t>(r.ptr - text.data());
  }
  return shape;
}

}  // namespace

NpyArray parse_npy(std::string_view bytes, const std::string& source) {
  if (bytes.size() < 10 || bytes.substr(0, 6) != std::string_view("\x93NUMPY", 6))
    throw InputError(source, 0, "not a .npy file (no \\x93NUMPY magic)");
  const int major = static_cast<unsigned char>(bytes[6]);
  const int length_bytes = major == 1 ? 2 : major == 2 ? 4 : 0;
  if (length_bytes == 0 || bytes.size() < 8U + static_cast<std::size_t>(length_bytes))
    throw InputError(source, 0, "unsupported .npy version " + std::to_string(major));
  const std::size_t start = 8 + static_cast<std::size_t>(length_bytes);
  const std::size_t length = get_le(bytes, 8, length_bytes);
  if (bytes.size() < start + length) throw InputError(source, 0, "truncated .npy header");
  const std::string header(bytes.substr(start, length));
  NpyArray a;
  const std::string descr = header_value(header, "descr", source);
  if (descr.size() < 2 || descr.front() != '\'' || descr.back() != '\'')
    throw InputError(source, 0, "npy descr is not a string: " + descr);
  a.descr = descr.substr(1, descr.size() - 2);
  if (header_value(header, "fortran_order", source) != "False")
    throw InputError(source, 0, "npy array is not in C order");
  a.shape = parse_shape(header_value(header, "shape", source), source);
  a.data = std::string(bytes.substr(start + length));
  const std::size_t item = item_size(a.descr);
  if (item == 0 || element_count(a.shape) * item != a.data.size())
    throw InputError(source, 0,
                     "npy data is " + std::to_string(a.data.size()) + " bytes, not what descr '" +
                         a.descr + "' and shape " + shape_text(a.shape) + " need");
  return a;
}

namespace {

constexpr std::uint32_t kLocalHeader = 0x04034b50;
constexpr std::uint32_t kCentralHeader = 0x02014b50;
constexpr std::uint32_t kEndOfCentral = 0x06054b50;
constexpr std::uint16_t kZipVersion = 20;                    // 2.0: stored members, no zip64
constexpr std::uint16_t kDosDate = (0 << 9) | (1 << 5) | 1;  // 1980-01-01

// The fields a local header and a central directory entry share, from
// "version needed" through the extra field's length.
void put_member_fields(std::string& out, const std::string& name, std::uint32_t crc,
                       std::size_t size) {
  put_le(out, kZipVersion, 2);
  put_le(out, 0, 2);  // flags
  put_le(out, 0, 2);  // method: stored
  put_le(out, 0, 2);  // time 00:00
  put_le(out, kDosDate, 2);
  put_le(out, crc, 4);
  put_le(out, size, 4);  // compressed
  put_le(out, size, 4);  // uncompressed
  put_le(out, name.size(), 2);
  put_le(out, 0, 2);  // extra field length
}

void check_members(const std::vector<std::pair<std::string, std::string>>& members,
                   const std::string& source) {
  std::set<std::string> names;
  std::size_t total = 22;
  for (const auto& [name, bytes] : members) {
    if (name.empty() || name.size() > 0xFFFF || !names.insert(name).second)
      throw InputError(source, 0,
                       "zip member name \"" + name + "\" is empty, too long or repeated");
    total += 30 + 46 + 2 * name.size() + bytes.size();
  }
  if (members.size() > 0xFFFF || total > std::numeric_limits<std::uint32_t>::max())
    throw InputError(source, 0,
                     "the arrays make " + std::to_string(total) +
                         " bytes: more than a zip without zip64 holds (4 GiB)");
}

}  // namespace

std::string zip_stored(const std::vector<std::pair<std::string, std::string>>& members,
                       const std::string& source) {
  check_members(members, source);
  std::string out, central;
  for (const auto& [name, bytes] : members) {
    const std::uint32_t crc = crc32(bytes);
    put_le(central, kCentralHeader, 4);
    put_le(central, kZipVersion, 2);  // made by: MS-DOS, version 2.0
    put_member_fields(central, name, crc, bytes.size());
    put_le(central, 0, 2);  // comment length
    put_le(central, 0, 2);  // disk number
    put_le(central, 0, 2);  // internal attributes
    put_le(central, 0, 4);  // external attributes
    put_le(central, out.size(), 4);
    central += name;
    put_le(out, kLocalHeader, 4);
    put_member_fields(out, name, crc, bytes.size());
    out += name;
    out += bytes;
  }
  const std::size_t central_at = out.size();
  out += central;
  put_le(out, kEndOfCentral, 4);
  put_le(out, 0, 2);  // this disk
  put_le(out, 0, 2);  // disk of the central directory
  put_le(out, members.size(), 2);
  put_le(out, members.size(), 2);
  put_le(out, central.size(), 4);
  put_le(out, central_at, 4);
  put_le(out, 0, 2);  // comment length
  return out;
}

namespace {

// One central directory entry at `at`: the member's name and bytes (checked
// against its local header and CRC-32); `at` moves past the entry.
std::pair<std::string, std::string> read_member(std::string_view bytes, std::size_t& at,
                                                const std::string& source) {
  const auto fail = [&source](const std::string& what) {
    throw InputError(source, 0, "zip: " + what);
  };
  if (at + 46 > bytes.size() || get_le(bytes, at, 4) != kCentralHeader)
    fail("bad central directory entry");
  const auto field = [&](std::size_t off, int n) { return get_le(bytes, at + off, n); };
  if (field(10, 2) != 0) fail("a member is compressed (only stored members are read)");
  const std::uint64_t crc = field(16, 4), size = field(20, 4), name_length = field(28, 2);
  const std::uint64_t skip = field(30, 2) + field(32, 2), local = field(42, 4);
  if (field(24, 4) != size || at + 46 + name_length > bytes.size()) fail("bad member sizes");
  std::string name(bytes.substr(at + 46, name_length));
  at += 46 + name_length + skip;
  if (local + 30 > bytes.size() || get_le(bytes, local, 4) != kLocalHeader)
    fail("member \"" + name + "\" has no local header");
  const std::uint64_t data =
      local + 30 + get_le(bytes, local + 26, 2) + get_le(bytes, local + 28, 2);
  if (data + size > bytes.size()) fail("member \"" + name + "\" is truncated");
  std::string content(bytes.substr(data, size));
  if (crc32(content) != crc) fail("member \"" + name + "\" fails its CRC-32");
  return {std::move(name), std::move(content)};
}

}  // namespace

std::vector<std::pair<std::string, std::string>> read_zip_stored(std::string_view bytes,
                                                                 const std::string& source) {
  if (bytes.size() < 22 || get_le(bytes, bytes.size() - 22, 4) != kEndOfCentral)
    throw InputError(source, 0, "zip: no end of central directory (or an archive comment)");
  const std::size_t end = bytes.size() - 22;
  const std::uint64_t count = get_le(bytes, end + 10, 2);
  std::size_t at = get_le(bytes, end + 16, 4);
  std::vector<std::pair<std::string, std::string>> members;
  for (std::uint64_t k = 0; k < count; ++k) members.push_back(read_member(bytes, at, source));
  return members;
}

}  // namespace mocap
