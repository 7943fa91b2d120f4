#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>

#include "io/npy.hpp"
#include "io/npz.hpp"
#include "potmap/data/labelled_points.hpp"
#include "potmap/error.hpp"
#include "potmap/io/map_io.hpp"
#include "test_support.hpp"

using namespace potmap;

namespace {

// Values with long binary expansions, tiny and huge magnitudes: any rounding in a writer shows.
KernelMap random_map(int dim, bool bias, std::size_t m, unsigned seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> pos(-5000.0, 5000.0), logu(-12.0, 5.0), w(-50.0, 50.0);
  KernelMap map;
  map.dim = dim;
  for (std::size_t i = 0; i < m; ++i) {
    double p[3] = {pos(rng), pos(rng) / 3.0, pos(rng) * 1e-3};
    map.push_back(p, std::pow(10.0, logu(rng)) / 3.0, w(rng) / 7.0,
                  i == 0 ? 0.0 : std::pow(10.0, 3 * logu(rng)));
  }
  map.has_bias = bias;
  if (bias) {
    map.bias_mean = -1.0 / 3.0;
    map.bias_var = 1e-300;
  }
  return map;
}

void write_text(const std::string& path, const std::string& text) {
  std::ofstream(path, std::ios::binary) << text;
}

std::string read_bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

// The message of the InputError `f` throws (fails the test if it throws nothing or another type).
template <class F>
std::string input_error(F&& f) {
  try {
    f();
  } catch (const InputError& e) {
    return e.what();
  } catch (const std::exception& e) {
    ADD_FAILURE() << "expected InputError, got: " << e.what();
    return "";
  }
  ADD_FAILURE() << "expected InputError, nothing thrown";
  return "";
}

#define EXPECT_CONTAINS(msg, part) \
  EXPECT_NE(std::string(msg).find(part), std::string::npos) << "message: " << (msg)

// CRC-32 (IEEE, reflected), written out here so the test does not reuse zlib's like the library.
std::uint32_t crc32_ieee(const std::string& s, std::size_t n) {
  std::uint32_t c = 0xffffffffu;
  for (std::size_t i = 0; i < n; ++i) {
    c ^= static_cast<unsigned char>(s[i]);
    for (int k = 0; k < 8; ++k) c = (c >> 1) ^ (0xedb88320u & (0u - (c & 1u)));
  }
  return ~c;
}

void put_u32(std::string& s, std::size_t at, std::uint32_t v) {
  for (int i = 0; i < 4; ++i) s[at + i] = static_cast<char>((v >> (8 * i)) & 0xff);
}
void put_u64(std::string& s, std::size_t at, std::uint64_t v) {
  for (int i = 0; i < 8; ++i) s[at + i] = static_cast<char>((v >> (8 * i)) & 0xff);
}
void reseal(std::string& s) {
  put_u32(s, s.size() - 4, crc32_ieee(s, s.size() - 4));
}

// A .npy image with the given header dict, written out here independently of npy::serialize.
std::string npy_image(const std::string& dict, const std::string& data, int major) {
  const std::string h = dict + "\n";
  std::string out = std::string("\x93NUMPY", 6) + char(major) + '\0';
  out += char(h.size() & 0xff);
  out += char(h.size() >> 8);
  if (major > 1) out += std::string(2, '\0');
  return out + h + data;
}

}  // namespace

// --- exact round trips ---------------------------------------------------------------------------

class MapRoundTrip : public ::testing::TestWithParam<std::tuple<std::string, int, bool>> {};

TEST_P(MapRoundTrip, IsExact) {
  const auto& [ext, dim, bias] = GetParam();
  const std::string dir = test::temp_dir("map_round_trip");
  KernelMap map = random_map(dim, bias, 257, 7 + dim);
  if (bias) map.cutoff_tau = 13.0 / 3.0;  // the maps with a bias carry a cut-off of their own
  const std::string path = dir + "/map" + ext;
  write_map(map, path);
  test::expect_same_map(map, read_map(path));
  // Empty maps keep their dimension too.
  KernelMap empty;
  empty.dim = dim;
  write_map(empty, path);
  const KernelMap back = read_map(path);
  EXPECT_EQ(back.dim, dim);
  EXPECT_TRUE(back.empty());
}

INSTANTIATE_TEST_SUITE_P(AllFormats, MapRoundTrip,
                         ::testing::Combine(::testing::Values(".csv", ".npz", ".potmap"),
                                            ::testing::Values(2, 3), ::testing::Bool()));

TEST(MapIo, WriteLeavesNoTemporaryAndReplacesAtomically) {
  const std::string dir = test::temp_dir("map_atomic");
  write_map(random_map(2, false, 10, 1), dir + "/a.potmap");
  write_map(random_map(2, false, 20, 2), dir + "/a.potmap");
  EXPECT_EQ(read_map(dir + "/a.potmap").size(), 20u);
  std::size_t files = 0;
  for (const auto& e : std::filesystem::directory_iterator(dir)) files += e.is_regular_file();
  EXPECT_EQ(files, 1u);
}

TEST(MapIo, WriterRejectsInvalidMapAndUnknownExtension) {
  const std::string dir = test::temp_dir("map_invalid");
  KernelMap m = random_map(2, false, 3, 1);
  m.gamma[1] = 0;
  EXPECT_THROW(write_map(m, dir + "/m.csv"), ArgumentError);
  EXPECT_FALSE(std::filesystem::exists(dir + "/m.csv"));
  EXPECT_THROW(write_map(random_map(2, false, 3, 1), dir + "/m.txt"), ArgumentError);
  EXPECT_CONTAINS(input_error([&] { read_map(dir + "/m.txt"); }), "m.txt");
  EXPECT_CONTAINS(input_error([&] { read_map(dir + "/nope.csv"); }), "nope.csv");
}

// --- the authors' real map -------------------------------------------------------------------

TEST(MapIo, RealNpzEqualsRealCsv) {
  const KernelMap npz = read_map(test::shared_data("carla/npz/town1_abhm_map.npz"));
  const KernelMap csv = read_map(test::shared_data("carla/town1_abhm_map.csv"));
  ASSERT_EQ(npz.size(), 92372u);
  ASSERT_EQ(csv.size(), 92372u);
  EXPECT_EQ(npz.dim, 2);
  EXPECT_EQ(csv.dim, 2);
  EXPECT_FALSE(npz.has_bias);
  // The CSV holds positions to 6 decimals and float32 values to 8 significant digits.
  double worst_pos = 0, worst_rel = 0;
  for (std::size_t i = 0; i < npz.position.size(); ++i)
    worst_pos = std::max(worst_pos, std::fabs(npz.position[i] - csv.position[i]));
  auto rel = [](double a, double b) { return std::fabs(a - b) / std::max(std::fabs(b), 1e-300); };
  for (std::size_t i = 0; i < npz.size(); ++i) {
    worst_rel = std::max(worst_rel, rel(npz.gamma[i], csv.gamma[i]));
    worst_rel = std::max(worst_rel, rel(npz.w_mean[i], csv.w_mean[i]));
    worst_rel = std::max(worst_rel, rel(npz.w_var[i], csv.w_var[i]));
  }
  EXPECT_LE(worst_pos, 5.01e-7);
  EXPECT_LE(worst_rel, 1.2e-7);  // float32 epsilon
}

TEST(MapIo, ReadsRealLabelledPoints) {
  const LabelledPoints p = read_labelled_csv(test::shared_data("carla/town1_test2k.csv"));
  ASSERT_EQ(p.size(), 2000u);
  EXPECT_EQ(p.dim, 2);
  EXPECT_EQ(p.position.size(), 4000u);
  std::size_t hits = 0;
  for (auto l : p.label) hits += l;
  EXPECT_EQ(hits, 1000u);
  // First row of the file: 87,-324.112660,47.366967,1
  EXPECT_EQ(p.scan[0], 87);
  EXPECT_EQ(p.position[0], -324.112660);
  EXPECT_EQ(p.position[1], 47.366967);
}

TEST(MapIo, LabelledPointsRoundTrip) {
  const std::string dir = test::temp_dir("labelled");
  for (int dim : {2, 3}) {
    LabelledPoints p;
    p.dim = dim;
    std::mt19937_64 rng(dim);
    std::uniform_real_distribution<double> u(-100, 100);
    for (int i = 0; i < 50; ++i) {
      for (int d = 0; d < dim; ++d) p.position.push_back(u(rng) / 3);
      p.label.push_back(i % 3 == 0);
      p.scan.push_back(i * 1000003LL);
    }
    write_labelled_csv(p, dir + "/p.csv");
    const LabelledPoints q = read_labelled_csv(dir + "/p.csv");
    EXPECT_EQ(q.dim, dim);
    EXPECT_EQ(q.position, p.position);
    EXPECT_EQ(q.label, p.label);
    EXPECT_EQ(q.scan, p.scan);
  }
}

// --- bad CSV input ---------------------------------------------------------------------------

struct BadCsv {
  const char* name;
  const char* text;
  const char* line;   // expected position in the message
  const char* value;  // expected offending value in the message
};

// Test names and failure messages show the case's name, not the struct's bytes.
void PrintTo(const BadCsv& c, std::ostream* os) {
  *os << c.name;
}

class MapCsvBadInput : public ::testing::TestWithParam<BadCsv> {};

TEST_P(MapCsvBadInput, NamesFileLineAndValue) {
  const BadCsv& c = GetParam();
  const std::string path = test::temp_dir("csv_bad") + "/bad_" + c.name + ".csv";
  write_text(path, c.text);
  const std::string msg = input_error([&] { read_map(path); });
  EXPECT_CONTAINS(msg, path);
  EXPECT_CONTAINS(msg, c.line);
  EXPECT_CONTAINS(msg, c.value);
}

INSTANTIATE_TEST_SUITE_P(
    Classes, MapCsvBadInput,
    ::testing::Values(
        BadCsv{"missing_column", "x,y,gamma,w_mean\n1,2,0.5,1\n", "line 1", "w_var"},
        BadCsv{"non_numeric", "x,y,gamma,w_mean,w_var\n1,2,0.5,1,1\n1,2,abc,1,1\n", "line 3",
               "'abc'"},
        BadCsv{"nan", "x,y,gamma,w_mean,w_var\n1,nan,0.5,1,1\n", "line 2", "'nan'"},
        BadCsv{"inf", "# c\nx,y,gamma,w_mean,w_var\n1,2,0.5,-inf,1\n", "line 3", "'-inf'"},
        BadCsv{"gamma", "x,y,gamma,w_mean,w_var\n1,2,-0.25,1,1\n", "line 2", "'-0.25'"},
        BadCsv{"gamma_zero", "x,y,gamma,w_mean,w_var\n1,2,0,1,1\n", "line 2", "gamma"},
        BadCsv{"w_var", "x,y,gamma,w_mean,w_var\n1,2,0.5,1,-3e-5\n", "line 2", "'-3e-5'"},
        BadCsv{"field_count", "x,y,gamma,w_mean,w_var\n1,2,0.5,1,1,9\n", "line 2", "found 6"},
        BadCsv{"truncated", "x,y,gamma,w_mean,w_var\n1,2,0.5,1,1\n3,4,0.", "line 3", "'3,4,0.'"},
        BadCsv{"bias", "# bias 1\nx,y,gamma,w_mean,w_var\n", "line 1", "'# bias 1'"},
        BadCsv{"bias_var", "# bias 1 -1\nx,y,gamma,w_mean,w_var\n", "line 1", "'-1'"},
        BadCsv{"cutoff_zero", "# cutoff 0\nx,y,gamma,w_mean,w_var\n", "line 1", "'0'"},
        BadCsv{"cutoff_count", "x,y,gamma,w_mean,w_var\n# cutoff 4 5\n", "line 2",
               "'# cutoff 4 5'"},
        BadCsv{"cutoff_twice", "# cutoff 4\n# cutoff 4\nx,y,gamma,w_mean,w_var\n", "line 2",
               "second cut-off"},
        BadCsv{"duplicate", "x,y,x,gamma,w_mean,w_var\n", "line 1", "'x'"},
        BadCsv{"trailing_junk", "x,y,gamma,w_mean,w_var\n1,2,0.5,1,1x\n", "line 2", "'1x'"}),
    [](const auto& info) { return std::string(info.param.name); });

TEST(MapIo, CsvColumnsByNameExtraColumnsAndBias) {
  const std::string path = test::temp_dir("csv_cols") + "/m.csv";
  write_text(path,
             "# written by hand\n# bias -2.5 0.125\nw_var,id,gamma,Y,X,z,w_mean\r\n"
             "0.5,a,2,20,10,30,-1\r\n\r\n4,b,3,21,11,31,+2\r\n");
  const KernelMap m = read_map(path);
  EXPECT_EQ(m.dim, 3);
  ASSERT_EQ(m.size(), 2u);
  EXPECT_EQ(m.position, (std::vector<double>{10, 20, 30, 11, 21, 31}));
  EXPECT_EQ(m.gamma, (std::vector<double>{2, 3}));
  EXPECT_EQ(m.w_mean, (std::vector<double>{-1, 2}));
  EXPECT_EQ(m.w_var, (std::vector<double>{0.5, 4}));
  EXPECT_TRUE(m.has_bias);
  EXPECT_EQ(m.bias_mean, -2.5);
  EXPECT_EQ(m.bias_var, 0.125);
}

TEST(MapIo, LabelledCsvBadInput) {
  const std::string dir = test::temp_dir("labelled_bad");
  write_text(dir + "/a.csv", "t,x,y,occupied\n1,2,3,1\n2,2,3,2\n");
  std::string msg = input_error([&] { read_labelled_csv(dir + "/a.csv"); });
  EXPECT_CONTAINS(msg, dir + "/a.csv");
  EXPECT_CONTAINS(msg, "line 3");
  EXPECT_CONTAINS(msg, "'2'");
  write_text(dir + "/b.csv", "t,x,y\n1,2,3\n");
  msg = input_error([&] { read_labelled_csv(dir + "/b.csv"); });
  EXPECT_CONTAINS(msg, "line 1");
  EXPECT_CONTAINS(msg, "occupied");
  write_text(dir + "/c.csv", "t,x,y,occupied\n1,2,3,1\n1,inf,3,0\n");
  msg = input_error([&] { read_labelled_csv(dir + "/c.csv"); });
  EXPECT_CONTAINS(msg, "line 3");
  EXPECT_CONTAINS(msg, "'inf'");
  write_text(dir + "/d.csv", "t,x,y,occupied\n1.5,2,3,1\n");
  msg = input_error([&] { read_labelled_csv(dir + "/d.csv"); });
  EXPECT_CONTAINS(msg, "'1.5'");
}

// --- bad native input ------------------------------------------------------------------------

TEST(MapIo, NativeBadInput) {
  const std::string dir = test::temp_dir("native_bad");
  const std::string good_path = dir + "/good.potmap";
  write_map(random_map(2, true, 5, 3), good_path);
  const std::string good = read_bytes(good_path);
  ASSERT_EQ(good.size(), 48u + 5 * 8 * 5 + 4);
  ASSERT_EQ(good.substr(0, 8), std::string("POTMAP\r\n"));
  const std::string path = dir + "/bad.potmap";
  auto check = [&](const std::string& bytes, const std::string& offset, const std::string& value) {
    write_text(path, bytes);
    const std::string msg = input_error([&] { read_map(path); });
    EXPECT_CONTAINS(msg, path);
    EXPECT_CONTAINS(msg, offset);
    EXPECT_CONTAINS(msg, value);
  };
  std::string b = good;
  b[0] = 'X';
  check(b, "byte offset 0", "magic");
  b = good;
  put_u32(b, 8, 7);
  check(b, "byte offset 8", "version 7");
  b = good;
  put_u32(b, 12, 4);
  check(b, "byte offset 12", "dimension 4");
  check(good.substr(0, good.size() - 9), "byte offset 16", "truncated");
  check(good.substr(0, 20), "byte offset 20", "truncated");
  check(good.substr(0, 5), "byte offset 5", "truncated");
  b = good;
  put_u64(b, 16, std::uint64_t(1) << 62);  // a count that would need exabytes
  check(b, "byte offset 16", "4611686018427387904");
  b = good;
  b[100] ^= 0x10;
  check(b, "byte offset " + std::to_string(good.size() - 4), "checksum");
  // Values are checked even when the checksum matches.
  b = good;
  const double neg = -0.75;
  std::uint64_t bits;
  std::memcpy(&bits, &neg, 8);
  const std::size_t gamma1 = 48 + 5 * 2 * 8 + 8;  // gamma of kernel 1
  put_u64(b, gamma1, bits);
  reseal(b);
  check(b, ("byte offset " + std::to_string(gamma1)).c_str(), "-0.75");
  b = good;
  const double nan = std::nan("");
  std::memcpy(&bits, &nan, 8);
  put_u64(b, 48, bits);
  reseal(b);
  check(b, "byte offset 48", "nan");

  // A map with its own cut-off: version 2, flag bit 2, the exponent right after w_var.
  KernelMap cut = random_map(2, false, 5, 3);
  cut.cutoff_tau = 4.5;
  write_map(cut, good_path);
  const std::string with_cut = read_bytes(good_path);
  ASSERT_EQ(with_cut.size(), 48u + 5 * 8 * 5 + 8 + 4);
  EXPECT_EQ(with_cut[8], 2);
  EXPECT_EQ(with_cut[24], 4);
  const std::size_t cut_at = 48 + 5 * 8 * 5;
  b = with_cut;
  const double zero = 0.0;
  std::memcpy(&bits, &zero, 8);
  put_u64(b, cut_at, bits);
  reseal(b);
  check(b, "byte offset " + std::to_string(cut_at), "cut-off exponent");
  // Version 1 has no such flag.
  b = good;
  put_u32(b, 24, 5);
  reseal(b);
  check(b, "byte offset 24", "unknown flags 5 in a version 1 map");
}

// --- bad NPZ input ---------------------------------------------------------------------------

TEST(MapIo, NpzBadInput) {
  const std::string dir = test::temp_dir("npz_bad");
  const std::string path = dir + "/bad.npz";
  using A = npy::Array;
  const std::size_t m = 4;
  const std::vector<double> ones(m, 1.0);
  auto base = [&] {
    std::vector<std::pair<std::string, A>> a;
    a.emplace_back("qhinge_mean", A::from_doubles(std::vector<double>(2 * m, 0.5), {m, 2}));
    a.emplace_back("qgamma_mean_forward", A::from_floats(std::vector<float>(m, 0.25f), {1, m}));
    a.emplace_back("qw_mean", A::from_doubles(ones, {m, 1}));
    a.emplace_back("qw_var", A::from_doubles(ones, {m}));
    return a;
  };
  npz::write(path, base());
  EXPECT_EQ(read_map(path).size(), m);

  auto check = [&](std::vector<std::pair<std::string, A>> arrays, const char* where,
                   const char* value) {
    npz::write(path, arrays);
    const std::string msg = input_error([&] { read_map(path); });
    EXPECT_CONTAINS(msg, path);
    EXPECT_CONTAINS(msg, where);
    EXPECT_CONTAINS(msg, value);
  };
  auto a = base();
  a.erase(a.begin() + 3);
  check(a, "qw_var", "missing");
  a = base();
  a[0].second = A::from_doubles(std::vector<double>(5 * m, 0.5), {m, 5});
  check(a, "qhinge_mean", "(4, 5)");
  a = base();
  a[3].second = A::from_doubles({1, 1, 1}, {3, 1});
  check(a, "qw_var", "(3, 1)");
  a = base();
  a[2].second = A::from_doubles({1, 1, std::nan(""), 1}, {m, 1});
  check(a, "qw_mean.npy[2]", "nan");
  a = base();
  a[1].second = A::from_doubles({1, -1, 1, 1}, {1, m});
  check(a, "qgamma_mean_forward.npy[1]", "-1");
  a = base();
  a[3].second = A::from_doubles({1, 1, 1, -2e-3}, {m});
  check(a, "qw_var.npy[3]", "-0.002");
  a = base();
  a.emplace_back("bias_mean", A::from_doubles({1.0}, {}));
  check(a, "bias_var", "both");

  // Not a zip at all, and a damaged member (stored data: the middle byte is array payload).
  write_text(path, "x,y,gamma\n");
  EXPECT_CONTAINS(input_error([&] { read_map(path); }), path);
  npz::write(path, base());
  std::string bytes = read_bytes(path);
  bytes[bytes.size() / 2] ^= 0x01;
  write_text(path, bytes);
  EXPECT_CONTAINS(input_error([&] { read_map(path); }), path);
}

// --- the npy codec ---------------------------------------------------------------------------

TEST(Npy, HeaderIsWhatNumpyWrites) {
  const npy::Array a = npy::Array::from_doubles({1, 2, 3, 4, 5, 6}, {3, 2});
  const std::string img = npy::serialize(a);
  const std::string dict = "{'descr': '<f8', 'fortran_order': False, 'shape': (3, 2), }";
  ASSERT_GE(img.size(), 10 + dict.size());
  EXPECT_EQ(img.substr(0, 8), std::string("\x93NUMPY\x01\x00", 8));
  const std::size_t hlen = static_cast<unsigned char>(img[8]) | static_cast<unsigned char>(img[9])
                                                                    << 8;
  EXPECT_EQ((10 + hlen) % 64, 0u);
  EXPECT_EQ(img.substr(10, dict.size()), dict);
  EXPECT_EQ(img[10 + hlen - 1], '\n');
  EXPECT_EQ(img.size(), 10 + hlen + 48);
  EXPECT_EQ(npy::serialize(npy::Array::from_doubles({7}, {1})).substr(10, 57),
            "{'descr': '<f8', 'fortran_order': False, 'shape': (1,), }");
}

TEST(Npy, ReadsFortranOrderBigEndianAndVersions) {
  // shape (2, 3) in Fortran order holds columns: [[1,2,3],[4,5,6]] is stored 1 4 2 5 3 6.
  std::string data;
  for (std::int32_t v : {1, 4, 2, 5, 3, 6})
    for (int i = 0; i < 4; ++i) data += char((v >> (8 * i)) & 0xff);
  for (int major : {1, 2, 3}) {
    const std::string img =
        npy_image("{'descr': '<i4', 'fortran_order': True, 'shape': (2, 3), }", data, major);
    const npy::Array a = npy::parse(img.data(), img.size(), "t");
    EXPECT_EQ(a.to_double(), (std::vector<double>{1, 2, 3, 4, 5, 6}));
  }
  std::string be;
  for (double v : {1.5, -2.0}) {
    std::uint64_t b;
    std::memcpy(&b, &v, 8);
    for (int i = 7; i >= 0; --i) be += char((b >> (8 * i)) & 0xff);
  }
  const std::string img =
      npy_image("{'shape': (2,), 'descr': '>f8', 'fortran_order': False}", be, 1);
  EXPECT_EQ(npy::parse(img.data(), img.size(), "t").to_double(), (std::vector<double>{1.5, -2.0}));
}

TEST(Npy, RejectsMalformedArrays) {
  const std::string good = npy::serialize(npy::Array::from_doubles({1, 2}, {2}));
  auto msg = [](const std::string& img) {
    return input_error([&] { npy::parse(img.data(), img.size(), "arr.npy"); });
  };
  std::string b = good;
  b[1] = 'X';
  EXPECT_CONTAINS(msg(b), "byte offset 0");
  b = good;
  b[6] = 4;
  EXPECT_CONTAINS(msg(b), "version 4.0");
  EXPECT_CONTAINS(msg(good.substr(0, good.size() - 3)), "truncated");
  EXPECT_CONTAINS(msg(good + "xx"), "trailing");
  EXPECT_CONTAINS(msg(good.substr(0, 4)), "truncated");
  b = good;
  b.replace(b.find("<f8"), 3, "<c8");
  EXPECT_CONTAINS(msg(b), "'<c8'");
  b = good;
  b.replace(b.find("(2,)"), 4, "(9,)");
  EXPECT_CONTAINS(msg(b), "(9,)");
  b = good;
  b.replace(b.find("'descr'"), 7, "'dtype'");
  EXPECT_CONTAINS(msg(b), "'dtype'");
  EXPECT_CONTAINS(
      msg(npy_image(
          "{'descr': '<f8', 'fortran_order': False, 'shape': (99999999999, 99999999999), }", "",
          1)),
      "too large");
  EXPECT_CONTAINS(msg(npy_image("{'descr': '<f8', 'fortran_order': False, 'shape': (2), }", "", 1)),
                  "(n,)");
}

// --- garbage never crashes -------------------------------------------------------------------

TEST(MapIo, RandomBytesAreRejectedCleanly) {
  const std::string dir = test::temp_dir("garbage");
  std::mt19937 rng(42);
  for (const char* ext : {".csv", ".npz", ".potmap"}) {
    for (int trial = 0; trial < 20; ++trial) {
      std::string bytes(static_cast<std::size_t>(rng() % 2000), '\0');
      for (char& c : bytes) c = static_cast<char>(rng());
      if (trial % 2 && std::string(ext) == ".potmap") bytes.replace(0, 8, "POTMAP\r\n", 8);
      const std::string path = dir + "/g" + ext;
      write_text(path, bytes);
      EXPECT_THROW(read_map(path), InputError) << ext << " trial " << trial;
    }
  }
  // A valid file cut at every length is rejected, never misread.
  for (const char* ext : {".npz", ".potmap"}) {
    const std::string path = dir + "/cut" + ext;
    write_map(random_map(3, true, 3, 5), path);
    const std::string full = read_bytes(path);
    for (std::size_t n = 0; n < full.size(); n += 7) {
      write_text(path, full.substr(0, n));
      EXPECT_THROW(read_map(path), InputError) << ext << " cut at " << n;
    }
  }
}
