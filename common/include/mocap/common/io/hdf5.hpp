#pragma once
// Small RAII layer over the HDF5 C API.
//
// Why the C API: full control over chunking, filters, the user block, file
// format bounds and error handling, with nothing hidden. Every hid_t lives in
// an `h5::Id` that closes it in its destructor, so no path closes a handle by
// hand. HDF5's automatic error printing is switched off; a failing call throws
// InputError(file, 0, "<object path>: <what was attempted>: <HDF5's reason>"),
// so a damaged or foreign file gives one clear message, never a crash or a
// dump of the HDF5 error stack. Every call's status is checked. Calling code
// that breaks an API contract (a value count that does not match the shape)
// gets std::invalid_argument instead.
//
// Types: numbers are stored little-endian (float32/64, int/uint 8..64), read
// into the native type of the caller's element. Strings are variable-length
// UTF-8. Shapes are row-major; the first dimension of an appendable dataset is
// unlimited and grows by `append_rows`.
//
// Threads: the Debian HDF5 build is thread-safe but serialises every call
// behind one global lock; callers that share a file between threads take
// `library_mutex()` around their own sequences of calls.
#include <hdf5.h>

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <mutex>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <type_traits>
#include <utility>
#include <vector>

namespace mocap::h5 {

/// Serialises HDF5 use across threads that share handles (see header comment).
std::mutex& library_mutex();

/// Owns one hid_t; closes it with the matching H5*close on destruction.
class Id {
 public:
  using Closer = herr_t (*)(hid_t);
  Id() = default;
  Id(hid_t id, Closer closer) : id_(id), closer_(closer) {}
  Id(const Id&) = delete;
  Id& operator=(const Id&) = delete;
  Id(Id&& o) noexcept : id_(std::exchange(o.id_, H5I_INVALID_HID)), closer_(o.closer_) {}
  Id& operator=(Id&& o) noexcept;
  ~Id() { reset(); }
  void reset();
  hid_t get() const { return id_; }
  bool valid() const { return id_ >= 0; }

 private:
  hid_t id_ = H5I_INVALID_HID;
  Closer closer_ = nullptr;
};

/// Element types the wrappers read and write.
template <class T>
concept Number = std::is_arithmetic_v<T> && !std::is_same_v<T, bool>;

/// Native (memory) and little-endian (file) HDF5 types of a C++ number type.
template <Number T>
hid_t native_type();
template <Number T>
hid_t file_type();

/// Dataset creation settings. `chunk_rows` = 0 makes a contiguous dataset of
/// fixed shape; otherwise the dataset is chunked (chunk_rows rows per chunk,
/// whole rows) and its first dimension unlimited. `deflate_level` 1..9 adds
/// shuffle + deflate (gzip) on chunked datasets, 0 none.
struct DatasetOptions {
  std::size_t chunk_rows = 0;
  int deflate_level = 0;
};

class Dataset;
class Group;

/// Common part of groups and datasets: attributes and error context.
class Object {
 public:
  hid_t id() const { return id_.get(); }
  /// "/skeletons/0/frames/local_rotations"
  const std::string& path() const { return path_; }
  /// The file (for error messages).
  const std::string& file() const { return file_; }

  bool has_attribute(const std::string& name) const;
  void set_attribute(const std::string& name, std::string_view value);
  void set_attribute(const std::string& name, const char* value) {
    set_attribute(name, std::string_view(value));
  }
  void set_attribute(const std::string& name, double value);
  void set_attribute(const std::string& name, std::int64_t value);
  void set_attribute(const std::string& name, std::uint64_t value);
  void set_attribute(const std::string& name, std::span<const double> values);
  /// Throws when absent or of another kind (string vs number).
  std::string string_attribute(const std::string& name) const;
  double double_attribute(const std::string& name) const;
  std::int64_t int_attribute(const std::string& name) const;
  std::vector<double> doubles_attribute(const std::string& name) const;
  /// Names of all attributes, sorted.
  std::vector<std::string> attribute_names() const;

  /// Throws InputError(file, 0, path + ": " + what [+ ": " + HDF5 reason]).
  [[noreturn]] void fail(const std::string& what) const;
  /// Throws std::invalid_argument(file: path: what): the calling code broke
  /// the API's contract (e.g. a value count that does not match the shape).
  [[noreturn]] void misuse(const std::string& what) const;

 protected:
  Object() = default;
  Object(Id id, std::string file, std::string path)
      : id_(std::move(id)), file_(std::move(file)), path_(std::move(path)) {}
  Id id_;
  std::string file_;
  std::string path_;
};

class Dataset : public Object {
 public:
  Dataset() = default;
  Dataset(Id id, std::string file, std::string path)
      : Object(std::move(id), std::move(file), std::move(path)) {}

  std::vector<hsize_t> shape() const;
  /// Number of rows (first dimension; 1 for a scalar).
  hsize_t rows() const;
  /// Elements per row (product of the other dimensions).
  hsize_t row_elements() const;
  /// H5T_FLOAT, H5T_INTEGER, H5T_STRING, H5T_ENUM, ...
  H5T_class_t type_class() const;
  /// True for a signed integer dataset (false for unsigned ones and other types).
  bool is_signed() const;
  /// Size in bytes of one stored element.
  std::size_t element_bytes() const;
  bool is_chunked() const;
  /// Filters in the pipeline ("shuffle", "deflate", ...).
  std::vector<std::string> filters() const;
  /// Bytes the data occupies in the file (after filters).
  hsize_t storage_bytes() const;

  /// Appends `count` rows (count * row_elements values) at the end of a
  /// chunked dataset.
  template <Number T>
  void append_rows(const T* values, hsize_t count);
  /// Writes the whole dataset (values.size() == product of shape).
  template <Number T>
  void write_all(std::span<const T> values);
  /// Reads rows [first, first + count).
  template <Number T>
  std::vector<T> read_rows(hsize_t first, hsize_t count) const;
  template <Number T>
  void read_rows_into(hsize_t first, hsize_t count, T* out) const;
  template <Number T>
  std::vector<T> read_all() const {
    return read_rows<T>(0, rows());
  }
  /// Variable-length UTF-8 strings (any shape, row-major).
  void write_strings(const std::vector<std::string>& values);
  std::vector<std::string> read_strings() const;
  /// Enumerated uint8 values (dataset created with Group::create_enum_dataset).
  void write_enum(std::span<const std::uint8_t> values);
  std::vector<std::uint8_t> read_enum() const;
  /// Names of the enum members, by value (empty for a non-enum dataset).
  std::vector<std::pair<std::string, int>> enum_members() const;

 private:
  void write_raw(hid_t mem_type, hid_t file_space, hsize_t first, hsize_t count,
                 const void* values);
  void read_raw(hid_t mem_type, hsize_t first, hsize_t count, void* out) const;
};

class Group : public Object {
 public:
  Group() = default;
  Group(Id id, std::string file, std::string path)
      : Object(std::move(id), std::move(file), std::move(path)) {}

  bool exists(const std::string& name) const;
  /// Names of members (groups and datasets), in name order.
  std::vector<std::string> members() const;
  bool is_group(const std::string& name) const;

  Group create_group(const std::string& name);
  Group open_group(const std::string& name) const;
  Dataset open_dataset(const std::string& name) const;

  /// A dataset of `shape` (for chunked ones the first dimension is the
  /// initial row count, normally 0) and element type T.
  template <Number T>
  Dataset create_dataset(const std::string& name, const std::vector<hsize_t>& shape,
                         const DatasetOptions& options = {});
  /// Variable-length UTF-8 string dataset of fixed shape.
  Dataset create_string_dataset(const std::string& name, const std::vector<hsize_t>& shape);
  /// uint8-based enum dataset of fixed shape; members are (name, value).
  Dataset create_enum_dataset(const std::string& name, hsize_t rows,
                              const std::vector<std::pair<std::string, int>>& members);

  /// Convenience: whole small datasets in one call.
  template <Number T>
  Dataset write_dataset(const std::string& name, const std::vector<hsize_t>& shape,
                        std::span<const T> values) {
    Dataset d = create_dataset<T>(name, shape);
    d.write_all<T>(values);
    return d;
  }
  Dataset write_strings(const std::string& name, const std::vector<hsize_t>& shape,
                        const std::vector<std::string>& values) {
    Dataset d = create_string_dataset(name, shape);
    d.write_strings(values);
    return d;
  }

 private:
  std::string child_path(const std::string& name) const;
};

/// An open HDF5 file; its root group is `root()`.
class File {
 public:
  File() = default;
  /// Creates (truncating) a file in the HDF5 1.10 format (metadata
  /// checksums), with a `userblock_bytes` user block at its start (0, or a
  /// power of two >= 512) that HDF5 leaves alone.
  static File create(const std::filesystem::path& path, hsize_t userblock_bytes = 0);
  /// Opens read-only (or read-write). Throws InputError for a missing,
  /// unreadable or non-HDF5 file.
  static File open(const std::filesystem::path& path, bool writable = false);

  Group& root() { return root_; }
  const Group& root() const { return root_; }
  const std::string& path() const { return path_; }
  /// Flushes and closes; further use is an error. Errors while closing throw.
  void close();

 private:
  std::string path_;
  Id file_;
  Group root_;
};

/// Throws InputError(file, 0, what + HDF5's innermost reason) after a failed call.
[[noreturn]] void throw_error(const std::string& file, const std::string& what);

}  // namespace mocap::h5
