// The .npz labelled-dataset reader, on archives built here byte by byte (stored, uncompressed
// members), so the test does not depend on NumPy or on the reader's own zip library to write.
#include <gtest/gtest.h>
#include <zlib.h>

#include <cstring>
#include <fstream>

#include "potmap/data/scan.hpp"
#include "potmap/error.hpp"
#include "test_support.hpp"

using namespace potmap;

namespace {

std::string npy_bytes(const std::string& descr, const std::string& shape, const std::string& body) {
  std::string h = "{'descr': '" + descr + "', 'fortran_order': False, 'shape': " + shape + ", }";
  while ((10 + h.size() + 1) % 64) h += ' ';
  h += '\n';
  std::string out = "\x93NUMPY\x01";
  out += '\0';
  out += static_cast<char>(h.size() & 0xff);
  out += static_cast<char>(h.size() >> 8);
  return out + h + body;
}

void le(std::string& s, std::uint32_t v, int n) {
  for (int k = 0; k < n; ++k) s += static_cast<char>((v >> (8 * k)) & 0xff);
}

std::string stored_zip(const std::vector<std::pair<std::string, std::string>>& files) {
  std::string out, central;
  for (const auto& [name, data] : files) {
    const std::uint32_t crc =
        crc32(0, reinterpret_cast<const Bytef*>(data.data()), static_cast<uInt>(data.size()));
    const std::uint32_t off = static_cast<std::uint32_t>(out.size());
    le(out, 0x04034b50, 4), le(out, 20, 2), le(out, 0, 2), le(out, 0, 2), le(out, 0, 4);
    le(out, crc, 4), le(out, data.size(), 4), le(out, data.size(), 4);
    le(out, name.size(), 2), le(out, 0, 2);
    out += name + data;
    le(central, 0x02014b50, 4), le(central, 20, 2), le(central, 20, 2), le(central, 0, 2);
    le(central, 0, 2), le(central, 0, 4), le(central, crc, 4), le(central, data.size(), 4);
    le(central, data.size(), 4), le(central, name.size(), 2), le(central, 0, 2);
    le(central, 0, 2), le(central, 0, 2), le(central, 0, 2), le(central, 0, 4), le(central, off, 4);
    central += name;
  }
  const std::uint32_t cd = static_cast<std::uint32_t>(out.size());
  out += central;
  le(out, 0x06054b50, 4), le(out, 0, 2), le(out, 0, 2), le(out, files.size(), 2);
  le(out, files.size(), 2), le(out, central.size(), 4), le(out, cd, 4), le(out, 0, 2);
  return out;
}

template <class T>
std::string raw(std::initializer_list<T> v) {
  std::string s(v.size() * sizeof(T), '\0');
  std::memcpy(s.data(), std::data(v), s.size());
  return s;
}

}  // namespace

TEST(NpzDataset, ReadsXAndY) {
  const std::string dir = test::temp_dir("npz_ok");
  const std::string p = dir + "/d.npz";
  std::ofstream(p, std::ios::binary) << stored_zip(
      {{"X.npy", npy_bytes("<f8", "(3, 3)", raw<double>({0, 1, 2, 0, 3, 4, 1, 5, 6}))},
       {"Y.npy", npy_bytes("<f8", "(3, 1)", raw<double>({1, 0, 1}))}});
  const LabelledPoints lp = read_npz_labelled(p);
  ASSERT_EQ(lp.size(), 3u);
  EXPECT_EQ(lp.dim, 2);
  EXPECT_EQ(lp.position, (std::vector<double>{1, 2, 3, 4, 5, 6}));
  EXPECT_EQ(lp.label, (std::vector<std::uint8_t>{1, 0, 1}));
  EXPECT_EQ(lp.scan, (std::vector<std::int64_t>{0, 0, 1}));
  const Dataset ds = read_dataset(p);
  EXPECT_EQ(ds.scans.size(), 2u);
}

TEST(NpzDataset, MismatchedLabelsNameTheFile) {
  const std::string dir = test::temp_dir("npz_bad");
  const std::string p = dir + "/d.npz";
  std::ofstream(p, std::ios::binary)
      << stored_zip({{"X.npy", npy_bytes("<f4", "(2, 4)", raw<float>({0, 1, 2, 3, 0, 4, 5, 6}))},
                     {"Y.npy", npy_bytes("|u1", "(3,)", std::string("\x01\x00\x01", 3))}});
  try {
    read_npz_labelled(p);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(p), std::string::npos);
    EXPECT_NE(std::string(e.what()).find("3 labels"), std::string::npos) << "[" << e.what() << "]";
  }
}

TEST(NpzDataset, MapArchiveWithoutXIsAnInputError) {
  // The authors' map archive holds kernels, not labelled samples: a clear error, not a crash.
  const std::string p = test::shared_data("carla/npz/town1_abhm_map.npz");
  try {
    read_npz_labelled(p);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("X.npy"), std::string::npos) << e.what();
  }
}
