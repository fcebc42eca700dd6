// Datasets (mocap/common/io/hdf5.hpp): the number-type maps, creation with chunking and
// filters, row appends and reads, strings and enumerations. Every call's
// status is checked (hdf5.cpp says how failures are reported).
#include <algorithm>
#include <string>
#include <vector>

#include "io/hdf5_internal.hpp"
#include "mocap/common/io/hdf5.hpp"
#include "mocap/common/util/error.hpp"

namespace mocap::h5 {

namespace detail {

/// A uint8 enumeration of `members` (`where`: file and path for errors).
Id enum_type(const std::vector<std::pair<std::string, int>>& members, const std::string& file,
             const std::string& where) {
  Id t = check(H5Tenum_create(H5T_NATIVE_UINT8), H5Tclose, file,
               where + ": cannot make an enumeration type");
  for (const auto& [name, value] : members) {
    const auto v = static_cast<std::uint8_t>(value);
    check_status(H5Tenum_insert(t.get(), name.c_str(), &v), file,
                 where + ": cannot add enumeration member '" + name + "'");
  }
  return t;
}

}  // namespace detail

using namespace detail;

template <>
hid_t native_type<float>() {
  return H5T_NATIVE_FLOAT;
}
template <>
hid_t native_type<double>() {
  return H5T_NATIVE_DOUBLE;
}
template <>
hid_t native_type<std::int8_t>() {
  return H5T_NATIVE_INT8;
}
template <>
hid_t native_type<std::uint8_t>() {
  return H5T_NATIVE_UINT8;
}
template <>
hid_t native_type<std::int32_t>() {
  return H5T_NATIVE_INT32;
}
template <>
hid_t native_type<std::uint32_t>() {
  return H5T_NATIVE_UINT32;
}
template <>
hid_t native_type<std::int64_t>() {
  return H5T_NATIVE_INT64;
}
template <>
hid_t native_type<std::uint64_t>() {
  return H5T_NATIVE_UINT64;
}
template <>
hid_t file_type<float>() {
  return H5T_IEEE_F32LE;
}
template <>
hid_t file_type<double>() {
  return H5T_IEEE_F64LE;
}
template <>
hid_t file_type<std::int8_t>() {
  return H5T_STD_I8LE;
}
template <>
hid_t file_type<std::uint8_t>() {
  return H5T_STD_U8LE;
}
template <>
hid_t file_type<std::int32_t>() {
  return H5T_STD_I32LE;
}
template <>
hid_t file_type<std::uint32_t>() {
  return H5T_STD_U32LE;
}
template <>
hid_t file_type<std::int64_t>() {
  return H5T_STD_I64LE;
}
template <>
hid_t file_type<std::uint64_t>() {
  return H5T_STD_U64LE;
}

namespace {

Id creation_plist(const std::string& file, const std::string& path,
                  const std::vector<hsize_t>& shape, const DatasetOptions& o) {
  Id dcpl = check(H5Pcreate(H5P_DATASET_CREATE), H5Pclose, file,
                  path + ": cannot make the creation properties");
  if (o.chunk_rows > 0) {
    std::vector<hsize_t> chunk = shape;
    if (chunk.empty())
      throw std::invalid_argument(file + ": " + path + ": a chunked dataset needs a rank");
    chunk[0] = o.chunk_rows;
    for (auto& c : chunk) c = std::max<hsize_t>(c, 1);
    check_status(H5Pset_chunk(dcpl.get(), static_cast<int>(chunk.size()), chunk.data()), file,
                 path + ": cannot set chunking");
    if (o.deflate_level > 0) {
      check_status(H5Pset_shuffle(dcpl.get()), file, path + ": cannot set the shuffle filter");
      check_status(H5Pset_deflate(dcpl.get(), static_cast<unsigned>(std::min(o.deflate_level, 9))),
                   file, path + ": cannot set the deflate filter");
    }
  }
  // Unwritten parts of chunks (the tail of the last one) are zeros, so that
  // files are reproducible and compress well.
  check_status(
      H5Pset_fill_time(dcpl.get(), o.chunk_rows > 0 ? H5D_FILL_TIME_ALLOC : H5D_FILL_TIME_NEVER),
      file, path + ": cannot set the fill time");
  return dcpl;
}

}  // namespace

template <Number T>
Dataset Group::create_dataset(const std::string& name, const std::vector<hsize_t>& shape,
                              const DatasetOptions& o) {
  silence();
  const std::string path = child_path(name);
  Id dcpl = creation_plist(file_, path, shape, o);
  Id space = simple_space(shape, o.chunk_rows > 0, file_, path);
  Id d = check(H5Dcreate2(id(), name.c_str(), file_type<T>(), space.get(), H5P_DEFAULT, dcpl.get(),
                          dataset_access(file_, path)),
               H5Dclose, file_, path + ": cannot create dataset");
  return Dataset(std::move(d), file_, path);
}

// ---------------------------------------------------------------------------
// Dataset

std::vector<hsize_t> Dataset::shape() const {
  silence();
  Id space = check(H5Dget_space(id()), H5Sclose, file_, path_ + ": cannot get its shape");
  const int rank = H5Sget_simple_extent_ndims(space.get());
  if (rank < 0) fail("cannot get its rank");
  std::vector<hsize_t> dims(static_cast<std::size_t>(rank));
  if (rank > 0 && H5Sget_simple_extent_dims(space.get(), dims.data(), nullptr) < 0)
    fail("cannot get its shape");
  return dims;
}

hsize_t Dataset::rows() const {
  const auto s = shape();
  return s.empty() ? 1 : s[0];
}

hsize_t Dataset::row_elements() const {
  return product(shape(), 1);
}

H5T_class_t Dataset::type_class() const {
  silence();
  Id t = check(H5Dget_type(id()), H5Tclose, file_, path_ + ": cannot get its type");
  return type_class_of(t.get(), file_, path_);
}

bool Dataset::is_signed() const {
  silence();
  Id t = check(H5Dget_type(id()), H5Tclose, file_, path_ + ": cannot get its type");
  if (type_class_of(t.get(), file_, path_) != H5T_INTEGER) return false;
  const H5T_sign_t sign = H5Tget_sign(t.get());
  if (sign == H5T_SGN_ERROR) fail("cannot get its sign");
  return sign == H5T_SGN_2;
}

std::size_t Dataset::element_bytes() const {
  silence();
  Id t = check(H5Dget_type(id()), H5Tclose, file_, path_ + ": cannot get its type");
  return type_size_of(t.get(), file_, path_);
}

bool Dataset::is_chunked() const {
  silence();
  Id p = check(H5Dget_create_plist(id()), H5Pclose, file_, path_ + ": cannot get its layout");
  const H5D_layout_t layout = H5Pget_layout(p.get());
  if (layout == H5D_LAYOUT_ERROR) fail("cannot get its layout");
  return layout == H5D_CHUNKED;
}

std::vector<std::string> Dataset::filters() const {
  silence();
  Id p = check(H5Dget_create_plist(id()), H5Pclose, file_, path_ + ": cannot get its filters");
  std::vector<std::string> out;
  const int n = H5Pget_nfilters(p.get());
  if (n < 0) fail("cannot get its filters");
  for (int i = 0; i < n; ++i) {
    unsigned flags = 0, config = 0;
    std::size_t nelem = 0;
    char name[64] = {0};
    const H5Z_filter_t f = H5Pget_filter2(p.get(), static_cast<unsigned>(i), &flags, &nelem,
                                          nullptr, sizeof name, name, &config);
    if (f == H5Z_FILTER_ERROR) fail("cannot get its filters");
    if (f == H5Z_FILTER_SHUFFLE)
      out.emplace_back("shuffle");
    else if (f == H5Z_FILTER_DEFLATE)
      out.emplace_back("deflate");
    else if (f == H5Z_FILTER_FLETCHER32)
      out.emplace_back("fletcher32");
    else
      out.emplace_back(name[0] ? name : "filter " + std::to_string(f));
  }
  return out;
}

hsize_t Dataset::storage_bytes() const {
  silence();
  // No error value to check: 0 is also what an unwritten dataset occupies.
  return H5Dget_storage_size(id());
}

void Dataset::write_raw(hid_t mem_type, hid_t file_space, hsize_t first, hsize_t count,
                        const void* values) {
  const auto dims = shape();
  std::vector<hsize_t> start(dims.size(), 0), extent = dims;
  if (!dims.empty()) {
    start[0] = first;
    extent[0] = count;
  }
  Id mem = make_space(extent, nullptr, file_, path_);
  if (!dims.empty())
    check_status(H5Sselect_hyperslab(file_space, H5S_SELECT_SET, start.data(), nullptr,
                                     extent.data(), nullptr),
                 file_, path_ + ": cannot select rows");
  check_status(H5Dwrite(id(), mem_type, mem.get(), file_space, H5P_DEFAULT, values), file_,
               path_ + ": cannot write rows " + std::to_string(first) + ".." +
                   std::to_string(first + count));
}

void Dataset::read_raw(hid_t mem_type, hsize_t first, hsize_t count, void* out) const {
  silence();
  const auto dims = shape();
  if (!dims.empty() && (first > dims[0] || count > dims[0] - first))
    throw InputError(file_, 0,
                     path_ + ": rows " + std::to_string(first) + ".." +
                         std::to_string(first + count) + " are out of range (it has " +
                         std::to_string(dims[0]) + ")");
  if (!dims.empty() && count == 0) return;
  Id space = check(H5Dget_space(id()), H5Sclose, file_, path_ + ": cannot get its shape");
  std::vector<hsize_t> start(dims.size(), 0), extent = dims;
  if (!dims.empty()) {
    start[0] = first;
    extent[0] = count;
    check_status(H5Sselect_hyperslab(space.get(), H5S_SELECT_SET, start.data(), nullptr,
                                     extent.data(), nullptr),
                 file_, path_ + ": cannot select rows");
  }
  Id mem = make_space(extent, nullptr, file_, path_);
  check_status(
      H5Dread(id(), mem_type, mem.get(), space.get(), H5P_DEFAULT, out), file_,
      path_ + ": cannot read rows " + std::to_string(first) + ".." + std::to_string(first + count));
}

template <Number T>
void Dataset::append_rows(const T* values, hsize_t count) {
  silence();
  if (count == 0) return;
  auto dims = shape();
  if (dims.empty()) fail("cannot append to a scalar dataset");
  const hsize_t first = dims[0];
  dims[0] += count;
  check_status(H5Dset_extent(id(), dims.data()), file_,
               path_ + ": cannot grow to " + std::to_string(dims[0]) + " rows");
  Id space = check(H5Dget_space(id()), H5Sclose, file_, path_ + ": cannot get its shape");
  write_raw(native_type<T>(), space.get(), first, count, values);
}

template <Number T>
void Dataset::write_all(std::span<const T> values) {
  silence();
  const auto dims = shape();
  if (values.size() != product(dims))
    misuse(std::to_string(values.size()) + " values for " + std::to_string(product(dims)) +
           " elements");
  if (values.empty()) return;
  Id space = check(H5Dget_space(id()), H5Sclose, file_, path_ + ": cannot get its shape");
  write_raw(native_type<T>(), space.get(), 0, dims.empty() ? 1 : dims[0], values.data());
}

template <Number T>
std::vector<T> Dataset::read_rows(hsize_t first, hsize_t count) const {
  std::vector<T> out(static_cast<std::size_t>(count * row_elements()));
  read_raw(native_type<T>(), first, count, out.data());
  return out;
}

template <Number T>
void Dataset::read_rows_into(hsize_t first, hsize_t count, T* out) const {
  read_raw(native_type<T>(), first, count, out);
}

#define MOCAP_H5_INSTANTIATE(T)                                                              \
  template void Dataset::append_rows<T>(const T*, hsize_t);                                  \
  template void Dataset::write_all<T>(std::span<const T>);                                   \
  template std::vector<T> Dataset::read_rows<T>(hsize_t, hsize_t) const;                     \
  template void Dataset::read_rows_into<T>(hsize_t, hsize_t, T*) const;                      \
  template Dataset Group::create_dataset<T>(const std::string&, const std::vector<hsize_t>&, \
                                            const DatasetOptions&);
MOCAP_H5_INSTANTIATE(float)
MOCAP_H5_INSTANTIATE(double)
MOCAP_H5_INSTANTIATE(std::int8_t)
MOCAP_H5_INSTANTIATE(std::uint8_t)
MOCAP_H5_INSTANTIATE(std::int32_t)
MOCAP_H5_INSTANTIATE(std::uint32_t)
MOCAP_H5_INSTANTIATE(std::int64_t)
MOCAP_H5_INSTANTIATE(std::uint64_t)
#undef MOCAP_H5_INSTANTIATE

void Dataset::write_strings(const std::vector<std::string>& values) {
  silence();
  const auto dims = shape();
  if (values.size() != product(dims)) misuse("string count does not match the shape");
  if (values.empty()) return;
  std::vector<const char*> ptrs(values.size());
  for (std::size_t i = 0; i < values.size(); ++i) ptrs[i] = values[i].c_str();
  Id t = string_type(file_, path_);
  check_status(H5Dwrite(id(), t.get(), H5S_ALL, H5S_ALL, H5P_DEFAULT, ptrs.data()), file_,
               path_ + ": cannot write strings");
}

std::vector<std::string> Dataset::read_strings() const {
  silence();
  if (type_class() != H5T_STRING) fail("is not a string dataset");
  const auto dims = shape();
  const hsize_t n = product(dims);
  std::vector<std::string> out;
  if (n == 0) return out;
  Id ftype = check(H5Dget_type(id()), H5Tclose, file_, path_ + ": cannot get its type");
  const htri_t variable = H5Tis_variable_str(ftype.get());
  if (variable < 0) fail("cannot get its string kind");
  if (variable == 0) fail("expected variable-length strings");
  Id t = string_type(file_, path_);
  std::vector<char*> ptrs(static_cast<std::size_t>(n), nullptr);
  check_status(H5Dread(id(), t.get(), H5S_ALL, H5S_ALL, H5P_DEFAULT, ptrs.data()), file_,
               path_ + ": cannot read strings");
  out.reserve(ptrs.size());
  for (char* p : ptrs) out.emplace_back(p ? p : "");
  Id space = check(H5Dget_space(id()), H5Sclose, file_, path_ + ": cannot get its shape");
#if H5_VERSION_GE(1, 12, 0)
  check_status(H5Treclaim(t.get(), space.get(), H5P_DEFAULT, ptrs.data()), file_,
               path_ + ": cannot free the strings read");
#else
  check_status(H5Dvlen_reclaim(t.get(), space.get(), H5P_DEFAULT, ptrs.data()), file_,
               path_ + ": cannot free the strings read");
#endif
  return out;
}

std::vector<std::pair<std::string, int>> Dataset::enum_members() const {
  silence();
  Id t = check(H5Dget_type(id()), H5Tclose, file_, path_ + ": cannot get its type");
  std::vector<std::pair<std::string, int>> out;
  if (type_class_of(t.get(), file_, path_) != H5T_ENUM) return out;
  const int n = H5Tget_nmembers(t.get());
  if (n < 0) fail("cannot count its enumeration members");
  Id base = check(H5Tget_super(t.get()), H5Tclose, file_, path_ + ": cannot get its base type");
  const bool one_byte = type_size_of(base.get(), file_, path_) == 1;
  for (int i = 0; i < n; ++i) {
    const auto member = static_cast<unsigned>(i);
    char* name = H5Tget_member_name(t.get(), member);
    if (!name) fail("cannot get the name of enumeration member " + std::to_string(i));
    std::string member_name = name;
    check_status(H5free_memory(name), file_, path_ + ": cannot free a member name");
    // Values of a wider base type are not read (the index's enums are uint8).
    std::uint8_t v = 0;
    if (one_byte)
      check_status(H5Tget_member_value(t.get(), member, &v), file_,
                   path_ + ": cannot get the value of enumeration member '" + member_name + "'");
    out.emplace_back(std::move(member_name), v);
  }
  return out;
}

void Dataset::write_enum(std::span<const std::uint8_t> values) {
  silence();
  if (values.size() != product(shape())) misuse("enum count does not match the shape");
  if (values.empty()) return;
  Id t = enum_type(enum_members(), file_, path_);
  check_status(H5Dwrite(id(), t.get(), H5S_ALL, H5S_ALL, H5P_DEFAULT, values.data()), file_,
               path_ + ": cannot write values");
}

std::vector<std::uint8_t> Dataset::read_enum() const {
  silence();
  if (type_class() != H5T_ENUM) fail("is not an enumeration");
  const auto members = enum_members();
  std::vector<std::uint8_t> out(static_cast<std::size_t>(product(shape())));
  if (out.empty()) return out;
  Id t = enum_type(members, file_, path_);
  check_status(H5Dread(id(), t.get(), H5S_ALL, H5S_ALL, H5P_DEFAULT, out.data()), file_,
               path_ + ": cannot read values");
  return out;
}

}  // namespace mocap::h5
