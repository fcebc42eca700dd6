#pragma once
// Large read-mostly tables and the page size they live on.
//
// The search engine's tables (scan tiles, sketches, chain sketches, block
// boxes) are hundreds of MB read at random: with 4 KiB pages nearly every
// tile a query scans costs a TLB miss and a page walk. On Linux with
// transparent huge pages in "madvise" mode (the Debian default) memory must
// ask for 2 MiB pages; assign_huge does, for the 2 MiB-aligned part of a
// vector's storage, before its pages are first written (docs/search.md
// "Tiles in one array, on huge pages").
#include <cstddef>
#include <vector>

namespace mocap {

/// Asks the kernel to back the whole 2 MiB pages inside [p, p + bytes) with
/// transparent huge pages (madvise MADV_HUGEPAGE). Effective for pages not
/// yet touched; a no-op for small ranges, where unsupported, or when the
/// kernel refuses (the memory then stays on ordinary pages: same contents).
void advise_huge_pages(void* p, std::size_t bytes) noexcept;

/// v = n copies of `value`, on fresh storage advised as huge pages before it
/// is written (vectors under 2 MiB are simply assigned).
template <class T>
void assign_huge(std::vector<T>& v, std::size_t n, const T& value) {
  constexpr std::size_t kHuge = std::size_t{2} << 20;
  if (n * sizeof(T) < kHuge) {
    v.assign(n, value);
    return;
  }
  std::vector<T>().swap(v);
  v.reserve(n);
  advise_huge_pages(v.data(), n * sizeof(T));
  v.assign(n, value);
}

}  // namespace mocap
