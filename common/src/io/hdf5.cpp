// The RAII layer over the HDF5 C API (mocap/common/io/hdf5.hpp): every call's status is
// checked; a failure throws InputError naming the file and the object path.
// (Closing a handle in a destructor is the one exception: it cannot report,
// so File::close() flushes first and reports that.)
#include "mocap/common/io/hdf5.hpp"

#include <algorithm>
#include <cstring>
#include <numeric>
#include <stdexcept>

#include "io/hdf5_internal.hpp"
#include "mocap/common/util/error.hpp"

namespace mocap::h5 {

namespace detail {

/// HDF5 keeps the error-printing setting per thread in thread-safe builds:
/// switch it off once in every thread that calls in.
/// The error API failing is a broken library, not bad input: logic_error.
// HDF5 registers a clean-up of its own with atexit. After a close that
// failed (a full disk: the flush fails), that clean-up closes the file again
// and crashes (SIGSEGV at exit). Every file and object here is closed by its
// owner (RAII), so the library's exit clean-up is switched off before any
// other HDF5 call (static initialisation).
const bool kNoHdf5Atexit = [] { return H5dont_atexit() >= 0; }();

void silence() {
  thread_local bool done = false;
  if (!done) {
    if (H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr) < 0)
      throw std::logic_error("HDF5: cannot switch off automatic error printing");
    done = true;
  }
}

/// Clears the current thread's error stack (after an expected failure).
void clear_error_stack() {
  if (H5Eclear2(H5E_DEFAULT) < 0) throw std::logic_error("HDF5: cannot clear the error stack");
}

Id check(hid_t id, herr_t (*closer)(hid_t), const std::string& file, const std::string& what) {
  if (id < 0) throw_error(file, what);
  return Id(id, closer);
}

void check_status(herr_t status, const std::string& file, const std::string& what) {
  if (status < 0) throw_error(file, what);
}

/// Variable-length UTF-8 strings (`where`: file and path for errors).
Id string_type(const std::string& file, const std::string& where) {
  Id t = check(H5Tcopy(H5T_C_S1), H5Tclose, file, where + ": cannot make a string type");
  check_status(H5Tset_size(t.get(), H5T_VARIABLE), file, where + ": cannot make a string type");
  check_status(H5Tset_cset(t.get(), H5T_CSET_UTF8), file, where + ": cannot make a string type");
  return t;
}

/// A type's class and size, checked.
H5T_class_t type_class_of(hid_t type, const std::string& file, const std::string& where) {
  const H5T_class_t c = H5Tget_class(type);
  if (c == H5T_NO_CLASS) throw_error(file, where + ": cannot get its type class");
  return c;
}
std::size_t type_size_of(hid_t type, const std::string& file, const std::string& where) {
  const std::size_t n = H5Tget_size(type);
  if (n == 0) throw_error(file, where + ": cannot get its type size");
  return n;
}

/// The one dataset-access property list of the process: a generous chunk
/// cache (521 slots, 1 MiB), as frame arrays are read in row ranges. It only
/// affects open handles, nothing written. `file` and `path` name the dataset
/// being opened in the error message of a failure to make it.
hid_t dataset_access(const std::string& file, const std::string& path) {
  static const Id dapl = [&] {
    Id p = check(H5Pcreate(H5P_DATASET_ACCESS), H5Pclose, file,
                 path + ": cannot make the dataset access properties");
    check_status(H5Pset_chunk_cache(p.get(), 521, 1u << 20, 1.0), file,
                 path + ": cannot set the chunk cache");
    return p;
  }();
  return dapl.get();
}

/// A dataspace of `dims` (scalar when empty); `max_dims` as H5Screate_simple's.
Id make_space(const std::vector<hsize_t>& dims, const hsize_t* max_dims, const std::string& file,
              const std::string& where) {
  return check(dims.empty()
                   ? H5Screate(H5S_SCALAR)
                   : H5Screate_simple(static_cast<int>(dims.size()), dims.data(), max_dims),
               H5Sclose, file, where + ": cannot make a dataspace");
}

hsize_t product(const std::vector<hsize_t>& v, std::size_t from) {
  hsize_t p = 1;
  for (std::size_t i = from; i < v.size(); ++i) p *= v[i];
  return p;
}

/// A dataspace of `shape`, its first dimension unlimited when `unlimited_rows`.
Id simple_space(const std::vector<hsize_t>& shape, bool unlimited_rows, const std::string& file,
                const std::string& path) {
  std::vector<hsize_t> maxdims = shape;
  if (unlimited_rows && !maxdims.empty()) maxdims[0] = H5S_UNLIMITED;
  return make_space(shape, maxdims.data(), file, path);
}

}  // namespace detail

using namespace detail;

namespace {

herr_t collect_error(unsigned, const H5E_error2_t* err, void* data) {
  auto* out = static_cast<std::vector<std::string>*>(data);
  if (err && err->desc && *err->desc) out->emplace_back(err->desc);
  return 0;
}

/// The innermost two entries of the current thread's error stack (the most
/// specific reasons), then the stack is cleared.
std::string take_reason() {
  std::vector<std::string> msgs;
  if (H5Ewalk2(H5E_DEFAULT, H5E_WALK_DOWNWARD, collect_error, &msgs) < 0)
    throw std::logic_error("HDF5: cannot read the error stack");
  clear_error_stack();
  if (msgs.empty()) return {};
  std::string r = msgs.back();
  if (msgs.size() >= 2 && msgs[msgs.size() - 2] != r) r = msgs[msgs.size() - 2] + ": " + r;
  return r;
}

}  // namespace

std::mutex& library_mutex() {
  static std::mutex m;
  return m;
}

void throw_error(const std::string& file, const std::string& what) {
  const std::string reason = take_reason();
  throw InputError(file, 0, reason.empty() ? what : what + " (" + reason + ")");
}

Id& Id::operator=(Id&& o) noexcept {
  if (this != &o) {
    reset();
    id_ = std::exchange(o.id_, H5I_INVALID_HID);
    closer_ = o.closer_;
  }
  return *this;
}

void Id::reset() {
  if (id_ >= 0 && closer_) {
    silence();
    closer_(id_);
  }
  id_ = H5I_INVALID_HID;
}

// ---------------------------------------------------------------------------
// Object: attributes

void Object::misuse(const std::string& what) const {
  throw std::invalid_argument(file_ + ": " + path_ + ": " + what);
}

void Object::fail(const std::string& what) const {
  throw_error(file_, path_ + ": " + what);
}

bool Object::has_attribute(const std::string& name) const {
  silence();
  const htri_t r = H5Aexists(id(), name.c_str());
  if (r < 0) fail("cannot query attribute '" + name + "'");
  return r > 0;
}

namespace {
void write_attribute(const Object& o, const std::string& name, hid_t file_type_id, hid_t mem_type,
                     const std::vector<hsize_t>& dims, const void* value) {
  silence();
  if (o.has_attribute(name))
    check_status(H5Adelete(o.id(), name.c_str()), o.file(),
                 o.path() + ": cannot replace attribute '" + name + "'");
  Id space = make_space(dims, nullptr, o.file(), o.path() + ": attribute '" + name + "'");
  Id attr =
      check(H5Acreate2(o.id(), name.c_str(), file_type_id, space.get(), H5P_DEFAULT, H5P_DEFAULT),
            H5Aclose, o.file(), o.path() + ": cannot create attribute '" + name + "'");
  check_status(H5Awrite(attr.get(), mem_type, value), o.file(),
               o.path() + ": cannot write attribute '" + name + "'");
}

Id open_attribute(const Object& o, const std::string& name) {
  silence();
  if (!o.has_attribute(name))
    throw InputError(o.file(), 0, o.path() + ": attribute '" + name + "' is missing");
  return check(H5Aopen(o.id(), name.c_str(), H5P_DEFAULT), H5Aclose, o.file(),
               o.path() + ": cannot open attribute '" + name + "'");
}

H5T_class_t attribute_class(const Object& o, const Id& attr, const std::string& name) {
  Id t =
      check(H5Aget_type(attr.get()), H5Tclose, o.file(), o.path() + ": attribute '" + name + "'");
  return type_class_of(t.get(), o.file(), o.path() + ": attribute '" + name + "'");
}

hssize_t attribute_points(const Object& o, const Id& attr, const std::string& name) {
  Id s =
      check(H5Aget_space(attr.get()), H5Sclose, o.file(), o.path() + ": attribute '" + name + "'");
  const hssize_t n = H5Sget_simple_extent_npoints(s.get());
  if (n < 0) throw_error(o.file(), o.path() + ": attribute '" + name + "': cannot get its size");
  return n;
}
}  // namespace

void Object::set_attribute(const std::string& name, std::string_view value) {
  Id t = string_type(file_, path_);
  const std::string s(value);
  const char* p = s.c_str();
  write_attribute(*this, name, t.get(), t.get(), {}, &p);
}
void Object::set_attribute(const std::string& name, double value) {
  write_attribute(*this, name, H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, {}, &value);
}
void Object::set_attribute(const std::string& name, std::int64_t value) {
  write_attribute(*this, name, H5T_STD_I64LE, H5T_NATIVE_INT64, {}, &value);
}
void Object::set_attribute(const std::string& name, std::uint64_t value) {
  write_attribute(*this, name, H5T_STD_U64LE, H5T_NATIVE_UINT64, {}, &value);
}
void Object::set_attribute(const std::string& name, std::span<const double> values) {
  write_attribute(*this, name, H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, {values.size()}, values.data());
}

std::string Object::string_attribute(const std::string& name) const {
  Id attr = open_attribute(*this, name);
  if (attribute_class(*this, attr, name) != H5T_STRING || attribute_points(*this, attr, name) != 1)
    throw InputError(file_, 0, path_ + ": attribute '" + name + "' is not a string");
  Id ftype = check(H5Aget_type(attr.get()), H5Tclose, file_, path_ + ": attribute '" + name + "'");
  const std::string where = path_ + ": attribute '" + name + "'";
  const htri_t variable = H5Tis_variable_str(ftype.get());
  if (variable < 0) throw_error(file_, where + ": cannot get its string kind");
  if (variable > 0) {
    Id t = string_type(file_, where);
    char* p = nullptr;
    check_status(H5Aread(attr.get(), t.get(), &p), file_,
                 path_ + ": cannot read attribute '" + name + "'");
    std::string out = p ? p : "";
    check_status(H5free_memory(p), file_, where + ": cannot free the string");
    return out;
  }
  const std::size_t n = type_size_of(ftype.get(), file_, where);
  std::string out(n, '\0');
  Id t = check(H5Tcopy(H5T_C_S1), H5Tclose, file_, where + ": cannot make a string type");
  check_status(H5Tset_size(t.get(), n), file_, where + ": cannot make a string type");
  check_status(H5Aread(attr.get(), t.get(), out.data()), file_,
               path_ + ": cannot read attribute '" + name + "'");
  out.resize(std::strlen(out.c_str()));
  return out;
}

double Object::double_attribute(const std::string& name) const {
  Id attr = open_attribute(*this, name);
  const H5T_class_t c = attribute_class(*this, attr, name);
  if ((c != H5T_FLOAT && c != H5T_INTEGER) || attribute_points(*this, attr, name) != 1)
    throw InputError(file_, 0, path_ + ": attribute '" + name + "' is not a number");
  double v = 0.0;
  check_status(H5Aread(attr.get(), H5T_NATIVE_DOUBLE, &v), file_,
               path_ + ": cannot read attribute '" + name + "'");
  return v;
}

std::int64_t Object::int_attribute(const std::string& name) const {
  Id attr = open_attribute(*this, name);
  if (attribute_class(*this, attr, name) != H5T_INTEGER || attribute_points(*this, attr, name) != 1)
    throw InputError(file_, 0, path_ + ": attribute '" + name + "' is not an integer");
  std::int64_t v = 0;
  check_status(H5Aread(attr.get(), H5T_NATIVE_INT64, &v), file_,
               path_ + ": cannot read attribute '" + name + "'");
  return v;
}

std::vector<double> Object::doubles_attribute(const std::string& name) const {
  Id attr = open_attribute(*this, name);
  const H5T_class_t c = attribute_class(*this, attr, name);
  if (c != H5T_FLOAT && c != H5T_INTEGER)
    throw InputError(file_, 0, path_ + ": attribute '" + name + "' is not numeric");
  const hssize_t n = attribute_points(*this, attr, name);
  if (n < 0) fail("attribute '" + name + "' has no extent");
  std::vector<double> v(static_cast<std::size_t>(n));
  check_status(H5Aread(attr.get(), H5T_NATIVE_DOUBLE, v.data()), file_,
               path_ + ": cannot read attribute '" + name + "'");
  return v;
}

namespace {
herr_t collect_name(hid_t, const char* name, const H5A_info_t*, void* data) {
  static_cast<std::vector<std::string>*>(data)->emplace_back(name);
  return 0;
}
herr_t collect_link(hid_t, const char* name, const H5L_info_t*, void* data) {
  static_cast<std::vector<std::string>*>(data)->emplace_back(name);
  return 0;
}
}  // namespace

std::vector<std::string> Object::attribute_names() const {
  silence();
  std::vector<std::string> names;
  hsize_t idx = 0;
  if (H5Aiterate2(id(), H5_INDEX_NAME, H5_ITER_INC, &idx, collect_name, &names) < 0)
    fail("cannot list attributes");
  std::sort(names.begin(), names.end());
  return names;
}

// ---------------------------------------------------------------------------
// Group

std::string Group::child_path(const std::string& name) const {
  return path_ == "/" ? "/" + name : path_ + "/" + name;
}

bool Group::exists(const std::string& name) const {
  silence();
  const htri_t r = H5Lexists(id(), name.c_str(), H5P_DEFAULT);
  if (r < 0) fail("cannot look up '" + name + "'");
  return r > 0;
}

std::vector<std::string> Group::members() const {
  silence();
  std::vector<std::string> names;
  hsize_t idx = 0;
  if (H5Literate(id(), H5_INDEX_NAME, H5_ITER_INC, &idx, collect_link, &names) < 0)
    fail("cannot list members");
  return names;
}

bool Group::is_group(const std::string& name) const {
  silence();
  Id obj = check(H5Oopen(id(), name.c_str(), H5P_DEFAULT), H5Oclose, file_,
                 child_path(name) + ": cannot open");
  const H5I_type_t type = H5Iget_type(obj.get());
  if (type == H5I_BADID) throw_error(file_, child_path(name) + ": cannot get its kind");
  return type == H5I_GROUP;
}

Group Group::create_group(const std::string& name) {
  silence();
  Id g = check(H5Gcreate2(id(), name.c_str(), H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), H5Gclose,
               file_, child_path(name) + ": cannot create group");
  return Group(std::move(g), file_, child_path(name));
}

Group Group::open_group(const std::string& name) const {
  silence();
  if (!exists(name)) throw InputError(file_, 0, child_path(name) + ": group is missing");
  Id g = check(H5Gopen2(id(), name.c_str(), H5P_DEFAULT), H5Gclose, file_,
               child_path(name) + ": cannot open group");
  return Group(std::move(g), file_, child_path(name));
}

Dataset Group::open_dataset(const std::string& name) const {
  silence();
  if (!exists(name)) throw InputError(file_, 0, child_path(name) + ": dataset is missing");
  Id d = check(H5Dopen2(id(), name.c_str(), dataset_access(file_, child_path(name))), H5Dclose,
               file_, child_path(name) + ": cannot open dataset");
  return Dataset(std::move(d), file_, child_path(name));
}

Dataset Group::create_string_dataset(const std::string& name, const std::vector<hsize_t>& shape) {
  silence();
  const std::string path = child_path(name);
  Id t = string_type(file_, path);
  Id space = simple_space(shape, false, file_, path);
  Id d = check(
      H5Dcreate2(id(), name.c_str(), t.get(), space.get(), H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT),
      H5Dclose, file_, path + ": cannot create dataset");
  return Dataset(std::move(d), file_, path);
}

Dataset Group::create_enum_dataset(const std::string& name, hsize_t rows,
                                   const std::vector<std::pair<std::string, int>>& members) {
  silence();
  const std::string path = child_path(name);
  Id t = enum_type(members, file_, path);
  Id space = make_space({rows}, nullptr, file_, path);
  Id d = check(
      H5Dcreate2(id(), name.c_str(), t.get(), space.get(), H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT),
      H5Dclose, file_, path + ": cannot create dataset");
  return Dataset(std::move(d), file_, path);
}

// ---------------------------------------------------------------------------
// File

File File::create(const std::filesystem::path& path, hsize_t userblock_bytes) {
  silence();
  File f;
  f.path_ = path.string();
  Id fcpl = check(H5Pcreate(H5P_FILE_CREATE), H5Pclose, f.path_,
                  "cannot make the file creation properties");
  if (userblock_bytes > 0)
    check_status(H5Pset_userblock(fcpl.get(), userblock_bytes), f.path_,
                 "cannot reserve the user block");
  Id fapl = check(H5Pcreate(H5P_FILE_ACCESS), H5Pclose, f.path_,
                  "cannot make the file access properties");
  // HDF5 1.10 file format: checksummed metadata, readable by HDF5 >= 1.10 (h5py too).
  check_status(H5Pset_libver_bounds(fapl.get(), H5F_LIBVER_V110, H5F_LIBVER_V110), f.path_,
               "cannot select the HDF5 1.10 file format");
  // Closing the file closes every object still open in it: when a write
  // fails (a full disk), no group or dataset outlives a file that could not
  // be flushed (HDF5 would otherwise crash closing them at exit).
  check_status(H5Pset_fclose_degree(fapl.get(), H5F_CLOSE_STRONG), f.path_,
               "cannot set the file close degree");
  f.file_ = check(H5Fcreate(f.path_.c_str(), H5F_ACC_TRUNC, fcpl.get(), fapl.get()), H5Fclose,
                  f.path_, "cannot create the file");
  f.root_ =
      Group(check(H5Gopen2(f.file_.get(), "/", H5P_DEFAULT), H5Gclose, f.path_, "cannot open /"),
            f.path_, "/");
  return f;
}

File File::open(const std::filesystem::path& path, bool writable) {
  silence();
  File f;
  f.path_ = path.string();
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) throw InputError(f.path_, 0, "no such file");
  const htri_t is_h5 = H5Fis_hdf5(f.path_.c_str());
  if (is_h5 <= 0) {
    clear_error_stack();
    throw InputError(f.path_, 0, "not an HDF5 file");
  }
  f.file_ = check(H5Fopen(f.path_.c_str(), writable ? H5F_ACC_RDWR : H5F_ACC_RDONLY, H5P_DEFAULT),
                  H5Fclose, f.path_, "cannot open the file");
  f.root_ =
      Group(check(H5Gopen2(f.file_.get(), "/", H5P_DEFAULT), H5Gclose, f.path_, "cannot open /"),
            f.path_, "/");
  return f;
}

void File::close() {
  silence();
  root_ = Group();
  if (file_.valid()) {
    const hid_t id = file_.get();
    const herr_t flushed = H5Fflush(id, H5F_SCOPE_LOCAL);
    file_.reset();
    if (flushed < 0) throw_error(path_, "cannot flush the file");
  }
}

}  // namespace mocap::h5
