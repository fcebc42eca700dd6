// The HDF5 layer (common/src/io/hdf5.cpp): round trips of numbers, strings,
// enums and attributes, and failures reported as InputError naming the file
// and the object.
#include "mocap/common/io/hdf5.hpp"

#include <gtest/gtest.h>

#include <stdexcept>
#include <string>
#include <vector>

#include "mocap/common/util/error.hpp"
#include "test_support.hpp"

namespace mocap {
namespace {

namespace fs = std::filesystem;

TEST(Hdf5, RoundTrips) {
  const fs::path path = test::temp_dir("hdf5-round-trip") / "t.h5";
  {
    h5::File f = h5::File::create(path, 512);
    h5::Group g = f.root().create_group("g");
    h5::Dataset rows =
        g.create_dataset<float>("rows", {0, 3}, {.chunk_rows = 4, .deflate_level = 4});
    const std::vector<float> values = {1, 2, 3, 4, 5, 6};
    rows.append_rows(values.data(), 2);
    rows.append_rows(values.data(), 1);
    g.write_dataset<std::int32_t>("ints", {3}, std::vector<std::int32_t>{-1, 0, 7});
    g.write_strings("names", {2}, {"a", "bé"});
    h5::Dataset e = g.create_enum_dataset("kind", 3, {{"x", 0}, {"y", 1}});
    e.write_enum(std::vector<std::uint8_t>{1, 0, 1});
    g.set_attribute("text", "hello");
    g.set_attribute("count", std::int64_t{-3});
    g.set_attribute("list", std::vector<double>{16, 64});
    f.close();
  }
  const h5::File f = h5::File::open(path);
  const h5::Group g = f.root().open_group("g");
  const h5::Dataset rows = g.open_dataset("rows");
  EXPECT_EQ(rows.shape(), (std::vector<hsize_t>{3, 3}));
  EXPECT_TRUE(rows.is_chunked());
  EXPECT_EQ(rows.filters(), (std::vector<std::string>{"shuffle", "deflate"}));
  EXPECT_EQ(rows.read_rows<float>(1, 2), (std::vector<float>{4, 5, 6, 1, 2, 3}));
  EXPECT_EQ(g.open_dataset("ints").read_all<std::int32_t>(), (std::vector<std::int32_t>{-1, 0, 7}));
  EXPECT_TRUE(g.open_dataset("ints").is_signed());
  EXPECT_FALSE(rows.is_signed());
  EXPECT_EQ(g.open_dataset("names").read_strings(), (std::vector<std::string>{"a", "bé"}));
  const h5::Dataset e = g.open_dataset("kind");
  EXPECT_EQ(e.read_enum(), (std::vector<std::uint8_t>{1, 0, 1}));
  EXPECT_EQ(e.enum_members(), (std::vector<std::pair<std::string, int>>{{"x", 0}, {"y", 1}}));
  EXPECT_EQ(g.string_attribute("text"), "hello");
  EXPECT_EQ(g.int_attribute("count"), -3);
  EXPECT_EQ(g.doubles_attribute("list"), (std::vector<double>{16, 64}));
}

/// The message of the InputError `f` throws ("" when none).
template <class F>
std::string error_of(F f) {
  try {
    f();
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

TEST(Hdf5, FailuresNameTheFileAndTheObject) {
  const fs::path path = test::temp_dir("hdf5-failures") / "t.h5";
  {
    h5::File f = h5::File::create(path);
    f.root().create_group("g").write_dataset<double>("d", {2}, std::vector<double>{1, 2});
    f.close();
  }
  const h5::File f = h5::File::open(path);  // read-only
  h5::Group g = f.root().open_group("g");
  std::string e = error_of([&] { g.open_dataset("missing"); });
  EXPECT_NE(e.find(path.string()), std::string::npos) << e;
  EXPECT_NE(e.find("/g/missing: dataset is missing"), std::string::npos) << e;
  e = error_of([&] { g.create_dataset<float>("new", {0, 3}, {.chunk_rows = 4}); });
  EXPECT_NE(e.find(path.string()), std::string::npos) << e;
  EXPECT_NE(e.find("/g/new: cannot create dataset"), std::string::npos) << e;
  e = error_of([&] { g.open_dataset("d").set_attribute("unit", "m"); });
  EXPECT_NE(e.find("/g/d: cannot create attribute 'unit'"), std::string::npos) << e;
  e = error_of([&] { g.open_dataset("d").string_attribute("unit"); });
  EXPECT_NE(e.find("/g/d: attribute 'unit' is missing"), std::string::npos) << e;
  // API misuse is a logic error: a chunked dataset needs a row dimension;
  // values must match the shape.
  h5::File w = h5::File::create(path.parent_path() / "w.h5");
  EXPECT_THROW(w.root().create_dataset<float>("scalar", {}, {.chunk_rows = 4}),
               std::invalid_argument);
  h5::Dataset two = w.root().create_dataset<double>("two", {2});
  EXPECT_THROW(two.write_all<double>(std::vector<double>{1, 2, 3}), std::invalid_argument);
  EXPECT_NE(error_of([&] { h5::File::open(path.parent_path() / "none.h5"); }).find("no such file"),
            std::string::npos);
}

}  // namespace
}  // namespace mocap
