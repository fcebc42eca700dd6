// common/src/io/npz.cpp: CRC-32, .npy arrays and stored zip archives.
// Invalid inputs first, then known values, then round trips (write -> read).
#include "mocap/common/io/npz.hpp"

#include <gtest/gtest.h>

#include <cstring>
#include <string>
#include <utility>
#include <vector>

#include "mocap/common/util/error.hpp"

using mocap::InputError;
using mocap::NpyArray;

TEST(Npz, RefusesInvalidInputs) {
  EXPECT_THROW(mocap::npy_float64({2, 3}, {1.0, 2.0}), std::invalid_argument);
  EXPECT_THROW(mocap::npy_bytes(NpyArray{"<f8", {2}, std::string(8, '\0')}), std::invalid_argument);
  EXPECT_THROW(mocap::npy_bytes(NpyArray{"f8", {1}, std::string(8, '\0')}), std::invalid_argument);
  EXPECT_THROW(mocap::parse_npy("", "a.npy"), InputError);
  EXPECT_THROW(mocap::parse_npy("NUMPY not really", "a.npy"), InputError);
  std::string truncated = mocap::npy_bytes(mocap::npy_int32({1, 2, 3}));
  truncated.pop_back();
  EXPECT_THROW(mocap::parse_npy(truncated, "a.npy"), InputError);
  std::string fortran = mocap::npy_bytes(mocap::npy_int32({1}));
  fortran.replace(fortran.find("False"), 5, "True ");
  EXPECT_THROW(mocap::parse_npy(fortran, "a.npy"), InputError);

  EXPECT_THROW(mocap::zip_stored({{"", "x"}}, "a.npz"), InputError);
  EXPECT_THROW(mocap::zip_stored({{"a.npy", "x"}, {"a.npy", "y"}}, "a.npz"), InputError);
  EXPECT_THROW(mocap::read_zip_stored("", "a.npz"), InputError);
  EXPECT_THROW(mocap::read_zip_stored("PK\3\4 not a whole archive at all", "a.npz"), InputError);
  std::string corrupt = mocap::zip_stored({{"a.npy", "payload"}}, "a.npz");
  corrupt[corrupt.find("payload")] = 'P';
  try {
    mocap::read_zip_stored(corrupt, "a.npz");
    FAIL() << "a member with a wrong CRC-32 was read";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("CRC-32"), std::string::npos) << e.what();
  }
}

TEST(Npz, Crc32KnownValues) {
  EXPECT_EQ(mocap::crc32(""), 0U);
  EXPECT_EQ(mocap::crc32("123456789"), 0xCBF43926U);
  EXPECT_EQ(mocap::crc32("The quick brown fox jumps over the lazy dog"), 0x414FA339U);
  EXPECT_EQ(mocap::crc32("56789", mocap::crc32("1234")), 0xCBF43926U);
}

TEST(Npz, NpyHeaderIsNumpys) {
  const std::string bytes = mocap::npy_bytes(mocap::npy_float64({2, 1, 3}, std::vector<double>(6)));
  ASSERT_GE(bytes.size(), 64U);
  EXPECT_EQ(bytes.substr(0, 8), std::string("\x93NUMPY\x01\x00", 8));
  const std::size_t header_length =
      static_cast<unsigned char>(bytes[8]) + 256U * static_cast<unsigned char>(bytes[9]);
  EXPECT_EQ((10 + header_length) % 64, 0U);
  EXPECT_EQ(bytes.size(), 10 + header_length + 6 * 8);
  const std::string header = bytes.substr(10, header_length);
  EXPECT_EQ(header.rfind("{'descr': '<f8', 'fortran_order': False, 'shape': (2, 1, 3), }", 0), 0U)
      << header;
  EXPECT_EQ(header.back(), '\n');
  EXPECT_NE(mocap::npy_bytes(mocap::npy_int32({7})).find("'shape': (1,)"), std::string::npos);
  EXPECT_NE(mocap::npy_bytes(mocap::npy_float64({}, {30.0})).find("'shape': ()"),
            std::string::npos);
}

TEST(Npz, StringsAreUtf32) {
  const NpyArray a = mocap::npy_strings({"Hips", "t\xC3\xA9", "bad\xFF"});
  EXPECT_EQ(a.descr, "<U4");
  ASSERT_EQ(a.data.size(), 3U * 4U * 4U);
  char32_t c[12];
  std::memcpy(c, a.data.data(), sizeof c);  // the test host is little-endian (x86, ARM)
  EXPECT_EQ(c[0], U'H');
  EXPECT_EQ(c[4 + 1], U'\u00E9');       // from its two UTF-8 bytes
  EXPECT_EQ(c[4 + 2], U'\0');           // shorter names are padded with zeros
  EXPECT_EQ(c[8 + 3], char32_t{0xFF});  // a lone 0xFF: its Latin-1 character
  EXPECT_EQ(mocap::npy_strings({}).descr, "<U1");
}

TEST(Npz, NpyRoundTrips) {
  const std::vector<NpyArray> arrays = {
      mocap::npy_float64({2, 2, 3}, {0, 1, -2, 3.5, 1e300, -1e-300, 6, 7, 8, 9, 10, 11}),
      mocap::npy_float64({}, {29.97}), mocap::npy_int32({-1, 0, 1, 1}),
      mocap::npy_strings({"Hips", "Spine"}), mocap::npy_float64({0, 4}, {})};
  for (const NpyArray& a : arrays) {
    const NpyArray b = mocap::parse_npy(mocap::npy_bytes(a), "a.npy");
    EXPECT_EQ(b.descr, a.descr);
    EXPECT_EQ(b.shape, a.shape);
    EXPECT_EQ(b.data, a.data);
  }
  const NpyArray one = mocap::npy_float64({1}, {-2.25});
  double v = 0;
  std::memcpy(&v, one.data.data(), sizeof v);
  EXPECT_EQ(v, -2.25);
}

TEST(Npz, ZipRoundTrips) {
  const std::vector<std::pair<std::string, std::string>> members = {
      {"positions.npy", mocap::npy_bytes(mocap::npy_float64({1, 1, 3}, {1, 2, 3}))},
      {"empty.npy", ""},
      {"names.npy", mocap::npy_bytes(mocap::npy_strings({"Hips"}))}};
  const std::string zip = mocap::zip_stored(members, "a.npz");
  EXPECT_EQ(zip.substr(0, 4), "PK\3\4");
  EXPECT_EQ(mocap::read_zip_stored(zip, "a.npz"), members);
  EXPECT_EQ(mocap::zip_stored(members, "a.npz"), zip);  // the same bytes every time
  const std::string none = mocap::zip_stored({}, "a.npz");
  EXPECT_EQ(none.size(), 22U);
  EXPECT_TRUE(mocap::read_zip_stored(none, "a.npz").empty());
}
