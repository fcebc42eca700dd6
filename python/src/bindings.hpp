#pragma once
// Shared pieces of the Python module's bindings (python/src/*.cpp): the open
// index held by Python, and numpy views of memory other objects own.
//
// Arrays the index holds (its frame arrays, loaded once and never changed)
// are handed to Python without copying: a read-only numpy array whose base
// is the Python object that owns the memory, so the memory lives as long as
// any array viewing it. Values the libraries compute on the fly (a
// synthesised motion, a BVH clip's poses) are copied into new arrays.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <algorithm>
#include <cstddef>
#include <memory>
#include <mutex>
#include <vector>

#include "mocap/common/io/index.hpp"
#include "mocap/search/search.hpp"

namespace mocap::python {

namespace py = pybind11;

/// An index opened from Python, with the search engine built on first use
/// (its tables, once built, serve every later search of this index).
class OpenIndex {
 public:
  explicit OpenIndex(Index index) : index_(std::move(index)) {}
  const Index& index() const { return index_; }
  /// The engine (built once, thread-safe).
  const SearchEngine& engine() const {
    std::call_once(engine_once_, [this] { engine_ = std::make_unique<SearchEngine>(index_); });
    return *engine_;
  }

 private:
  Index index_;
  mutable std::once_flag engine_once_;
  mutable std::unique_ptr<SearchEngine> engine_;
};

/// A read-only numpy view of `data` with shape `shape` (C order), kept alive
/// by `owner` (the array's base).
template <typename T>
py::array readonly_view(const T* data, const std::vector<std::size_t>& shape,
                        const py::object& owner) {
  std::vector<py::ssize_t> dims(shape.begin(), shape.end());
  std::vector<py::ssize_t> strides(shape.size());
  py::ssize_t stride = sizeof(T);
  for (std::size_t i = shape.size(); i-- > 0;) {
    strides[i] = stride;
    stride *= dims[i];
  }
  py::array a(py::dtype::of<T>(), dims, strides, data, owner);
  py::detail::array_proxy(a.ptr())->flags &= ~py::detail::npy_api::NPY_ARRAY_WRITEABLE_;
  return a;
}

/// A new (owning, writable) array of `shape` filled from `values` (C order).
template <typename T>
py::array_t<T> owned_array(const std::vector<std::size_t>& shape, const std::vector<T>& values) {
  std::vector<py::ssize_t> dims(shape.begin(), shape.end());
  py::array_t<T> a(dims);
  std::copy(values.begin(), values.end(), a.mutable_data());
  return a;
}

void bind_index(py::module_& m);
void bind_search(py::module_& m);
void bind_synth(py::module_& m);
void bind_bvh(py::module_& m);
void bind_style(py::module_& m);

}  // namespace mocap::python
