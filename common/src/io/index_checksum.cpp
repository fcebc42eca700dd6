// Dataset checksums of an index (index_checksum.hpp).
#include "io/index_checksum.hpp"

#include <algorithm>
#include <cmath>
#include <string>
#include <type_traits>
#include <vector>

#include "mocap/common/util/error.hpp"
#include "mocap/common/util/xxh64.hpp"

namespace mocap {

std::uint64_t dataset_checksum(const h5::Dataset& d, ValueFindings* findings, bool quaternions) {
  Xxh64 h;
  const H5T_class_t cls = d.type_class();
  if (cls == H5T_STRING) {
    for (const auto& s : d.read_strings()) h.update(s.c_str(), s.size() + 1);
    return h.digest();
  }
  if (cls == H5T_ENUM) {
    const auto v = d.read_enum();
    h.update(v.data(), v.size());
    return h.digest();
  }
  const std::size_t bytes = d.element_bytes();
  const hsize_t rows = d.rows();
  const hsize_t per_row = std::max<hsize_t>(d.row_elements(), 1);
  const hsize_t step = std::max<hsize_t>(1, (hsize_t{1} << 20) / per_row);
  auto run = [&](auto tag) {
    using T = decltype(tag);
    if (d.shape().empty()) {
      const auto v = d.read_rows<T>(0, 1);
      h.update(v.data(), v.size() * sizeof(T));
      return;
    }
    std::vector<T> buf;
    for (hsize_t r = 0; r < rows; r += step) {
      const hsize_t n = std::min(step, rows - r);
      buf.resize(static_cast<std::size_t>(n * per_row));
      d.read_rows_into<T>(r, n, buf.data());
      h.update(buf.data(), buf.size() * sizeof(T));
      if constexpr (std::is_floating_point_v<T>) {
        if (!findings) continue;
        const std::uint64_t base = r * per_row;
        for (std::size_t i = 0; i < buf.size() && findings->first_non_finite == UINT64_MAX; ++i)
          if (!std::isfinite(buf[i])) findings->first_non_finite = base + i;
        if (quaternions)
          for (std::size_t i = 0;
               i + 3 < buf.size() && findings->first_bad_quaternion == UINT64_MAX; i += 4) {
            double n2 = 0.0;
            for (std::size_t e = 0; e < 4; ++e)
              n2 += static_cast<double>(buf[i + e]) * static_cast<double>(buf[i + e]);
            if (std::abs(std::sqrt(n2) - 1.0) > 1e-3 || buf[i] < T(0))
              findings->first_bad_quaternion = (base + i) / 4;
          }
      }
    }
  };
  if (cls == H5T_FLOAT) {
    if (bytes == 4)
      run(float{});
    else
      run(double{});
  } else if (cls == H5T_INTEGER) {
    const bool is_signed = d.is_signed();
    switch (bytes) {
      case 1:
        is_signed ? run(std::int8_t{}) : run(std::uint8_t{});
        break;
      case 4:
        is_signed ? run(std::int32_t{}) : run(std::uint32_t{});
        break;
      case 8:
        is_signed ? run(std::int64_t{}) : run(std::uint64_t{});
        break;
      default:
        throw InputError(d.file(), 0, d.path() + ": unexpected integer size");
    }
  } else {
    throw InputError(d.file(), 0, d.path() + ": unexpected data type");
  }
  return h.digest();
}

void check_group_checksums(const h5::Group& g) {
  for (const auto& name : g.members()) {
    if (g.is_group(name)) continue;
    const h5::Dataset d = g.open_dataset(name);
    if (!d.has_attribute("checksum_xxh64"))
      throw InputError(d.file(), 0, d.path() + ": checksum_xxh64 attribute is missing");
    if (hex64(dataset_checksum(d)) != d.string_attribute("checksum_xxh64"))
      throw InputError(d.file(), 0, d.path() + ": checksum mismatch (the index is damaged)");
  }
}

}  // namespace mocap
