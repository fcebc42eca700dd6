#pragma once
// Checked building blocks shared by hdf5.cpp and hdf5_dataset.cpp (not part
// of the public API): each throws InputError(file, 0, "<where>: <what>: <HDF5's
// reason>") when its HDF5 call fails.
#include <hdf5.h>

#include <cstddef>
#include <string>
#include <utility>
#include <vector>

#include "mocap/common/io/hdf5.hpp"

namespace mocap::h5::detail {

/// Switches off HDF5's error printing once per thread (std::logic_error if
/// the error API itself fails).
void silence();
/// Clears the current thread's error stack (after an expected failure).
void clear_error_stack();
/// `id` owned with `closer`; throws when id < 0.
Id check(hid_t id, herr_t (*closer)(hid_t), const std::string& file, const std::string& what);
/// Throws when status < 0.
void check_status(herr_t status, const std::string& file, const std::string& what);
/// Variable-length UTF-8 strings (`where`: file and path for errors).
Id string_type(const std::string& file, const std::string& where);
/// A uint8 enumeration of `members`.
Id enum_type(const std::vector<std::pair<std::string, int>>& members, const std::string& file,
             const std::string& where);
/// A type's class and size in bytes.
H5T_class_t type_class_of(hid_t type, const std::string& file, const std::string& where);
std::size_t type_size_of(hid_t type, const std::string& file, const std::string& where);
/// The process's one dataset-access property list (chunk cache).
hid_t dataset_access(const std::string& file, const std::string& path);
/// A dataspace of `dims` (scalar when empty); `max_dims` as H5Screate_simple's.
Id make_space(const std::vector<hsize_t>& dims, const hsize_t* max_dims, const std::string& file,
              const std::string& where);
/// A dataspace of `shape`, its first dimension unlimited when `unlimited_rows`.
Id simple_space(const std::vector<hsize_t>& shape, bool unlimited_rows, const std::string& file,
                const std::string& path);
/// Product of v[from..].
hsize_t product(const std::vector<hsize_t>& v, std::size_t from = 0);

}  // namespace mocap::h5::detail
