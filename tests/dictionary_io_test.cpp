#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <random>
#include <sstream>

#include "io/le_bytes.hpp"
#include "potmap/pot/dictionary_io.hpp"
#include "test_support.hpp"

using namespace potmap;

namespace {

// Values with long binary expansions: any rounding in the writer shows up in the round trip.
Dictionary random_dictionary(int dim, std::size_t atoms, unsigned seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Dictionary d;
  d.dim = dim;
  d.scale = 1.0 / 47.0;
  d.max_range = 19.75;
  d.sectors = 7;
  for (std::size_t a = 0; a < atoms; ++a) {
    Atom at;
    at.sector.dim = dim;
    at.sector.index = static_cast<int>(a % 7);
    at.sector.scale = d.scale;
    at.sector.max_range = 17.0 + a / 3.0;
    for (int k = 0; k < 3; ++k) {
      at.sector.centre[k] = k < dim ? 1e5 * u(rng) : 0;
      at.sector.sensor[k] = k < dim ? 1e5 * u(rng) : 0;
    }
    const std::size_t nh = a == 1 ? 0 : 3 + a, nf = a == 2 ? 0 : 2 + 2 * a;
    for (std::size_t i = 0; i < nh * dim; ++i) at.sector.hits.push_back(u(rng) / 3.0);
    for (std::size_t i = 0; i < nf * dim; ++i) at.sector.free.push_back(u(rng) / 7.0);
    at.kernels.dim = dim;
    for (std::size_t k = 0; k < 1 + a % 4; ++k) {
      const double p[3] = {u(rng), u(rng), u(rng)};
      at.kernels.push_back(p, std::exp(5 * u(rng)), 30 * u(rng), std::exp(10 * u(rng)));
    }
    at.scan_index = static_cast<std::int64_t>(a) * 1000003 - 5;
    at.source = a % 2 ? "town1 seed 3 / map bhm.potmap" : "";
    d.atoms.push_back(std::move(at));
  }
  return d;
}

void expect_same(const Dictionary& a, const Dictionary& b) {
  ASSERT_EQ(a.dim, b.dim);
  EXPECT_EQ(a.scale, b.scale);
  EXPECT_EQ(a.max_range, b.max_range);
  EXPECT_EQ(a.sectors, b.sectors);
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t i = 0; i < a.size(); ++i) {
    const Atom &x = a.atoms[i], &y = b.atoms[i];
    EXPECT_EQ(x.sector.dim, y.sector.dim);
    EXPECT_EQ(x.sector.index, y.sector.index);
    EXPECT_EQ(x.sector.centre, y.sector.centre);
    EXPECT_EQ(x.sector.sensor, y.sector.sensor);
    EXPECT_EQ(x.sector.scale, y.sector.scale);
    EXPECT_EQ(x.sector.max_range, y.sector.max_range);
    EXPECT_EQ(x.sector.hits, y.sector.hits);
    EXPECT_EQ(x.sector.free, y.sector.free);
    EXPECT_EQ(x.kernels.dim, y.kernels.dim);
    EXPECT_EQ(x.kernels.position, y.kernels.position);
    EXPECT_EQ(x.kernels.gamma, y.kernels.gamma);
    EXPECT_EQ(x.kernels.w_mean, y.kernels.w_mean);
    EXPECT_EQ(x.kernels.w_var, y.kernels.w_var);
    EXPECT_EQ(x.scan_index, y.scan_index);
    EXPECT_EQ(x.source, y.source);
  }
}

void spit(const std::string& p, const std::string& bytes) {
  std::ofstream(p, std::ios::binary) << bytes;
}
// Rewrites the trailing checksum so that a corruption reaches the field checks.
void fix_crc(std::string& bytes) {
  std::string crc;
  detail::put_u32(crc, detail::crc32_of(reinterpret_cast<const unsigned char*>(bytes.data()),
                                        bytes.size() - 4));
  bytes.replace(bytes.size() - 4, 4, crc);
}
void put_f64_at(std::string& bytes, std::size_t at, double v) {
  std::string s;
  detail::put_f64(s, v);
  bytes.replace(at, 8, s);
}
void put_u32_at(std::string& bytes, std::size_t at, std::uint32_t v) {
  std::string s;
  detail::put_u32(s, v);
  bytes.replace(at, 4, s);
}
void put_u64_at(std::string& bytes, std::size_t at, std::uint64_t v) {
  std::string s;
  detail::put_u64(s, v);
  bytes.replace(at, 8, s);
}

// The message of the InputError reading `bytes` throws (fails the test if none).
std::string read_error(const std::string& path, const std::string& bytes) {
  spit(path, bytes);
  try {
    read_dictionary(path);
  } catch (const InputError& e) {
    return e.what();
  }
  ADD_FAILURE() << "no InputError";
  return "";
}

}  // namespace

TEST(DictionaryIo, RoundTripIsExact2dAnd3d) {
  const std::string dir = test::temp_dir("dict_io_roundtrip");
  for (int dim : {2, 3}) {
    const Dictionary d = random_dictionary(dim, 9, 11 + dim);
    const std::string p = dir + "/d" + std::to_string(dim) + ".potdict";
    write_dictionary(d, p);
    expect_same(d, read_dictionary(p));
  }
  Dictionary empty;
  write_dictionary(empty, dir + "/empty.potdict");
  expect_same(empty, read_dictionary(dir + "/empty.potdict"));
}

TEST(DictionaryIo, EveryTruncationIsAnInputErrorNamingTheFile) {
  const std::string dir = test::temp_dir("dict_io_truncate");
  const std::string p = dir + "/d.potdict", q = dir + "/t.potdict";
  write_dictionary(random_dictionary(2, 4, 3), p);
  const std::string bytes = potmap::test::file_bytes(p);
  ASSERT_GT(bytes.size(), 500u);
  // Every section boundary of every atom, a byte either side, every header length, every 11th.
  const Dictionary d = read_dictionary(p);
  std::vector<std::size_t> cuts;
  std::size_t at = 64;
  for (const Atom& a : d.atoms) {
    const std::size_t D = 2, nk = a.kernels.size();
    for (std::size_t len : {std::size_t(112), a.source.size(), 8 * D * a.sector.num_hits(),
                            8 * D * a.sector.num_free(), 8 * D * nk, 8 * nk, 8 * nk, 8 * nk}) {
      cuts.push_back(at);
      at += len;
    }
  }
  ASSERT_EQ(at + 4, bytes.size());
  for (std::size_t c : std::vector<std::size_t>(cuts))
    for (std::size_t n : {c - 1, c + 1}) cuts.push_back(n);
  for (std::size_t n = 0; n < bytes.size(); n += n < 64 ? 1 : 11) cuts.push_back(n);
  for (std::size_t n : cuts) {
    if (n >= bytes.size()) continue;
    const std::string msg = read_error(q, bytes.substr(0, n));
    ASSERT_NE(msg.find(q), std::string::npos) << n << ": " << msg;
    ASSERT_NE(msg.find("byte offset"), std::string::npos) << n << ": " << msg;
    if (n >= 64) ASSERT_NE(msg.find("truncated"), std::string::npos) << n << ": " << msg;
  }
  // Trailing garbage is refused too.
  EXPECT_NE(read_error(q, bytes + "x").find("file has"), std::string::npos);
}

TEST(DictionaryIo, EveryFlippedByteIsDetected) {
  const std::string dir = test::temp_dir("dict_io_flip");
  const std::string p = dir + "/d.potdict", q = dir + "/f.potdict";
  write_dictionary(random_dictionary(3, 3, 5), p);
  const std::string bytes = potmap::test::file_bytes(p);
  for (std::size_t i = 0; i < bytes.size(); i += i < 200 ? 1 : 7) {
    std::string b = bytes;
    b[i] = static_cast<char>(b[i] ^ (1 << (i % 8)));
    const std::string msg = read_error(q, b);
    ASSERT_NE(msg.find("byte offset"), std::string::npos) << i << ": " << msg;
  }
}

TEST(DictionaryIo, BadHeaderFieldsNameOffsetAndValue) {
  const std::string dir = test::temp_dir("dict_io_header");
  const std::string p = dir + "/d.potdict", q = dir + "/h.potdict";
  write_dictionary(random_dictionary(2, 2, 7), p);
  const std::string bytes = potmap::test::file_bytes(p);

  std::string b = bytes;
  b[0] = 'X';
  EXPECT_NE(read_error(q, b).find("byte offset 0: not a potmap dictionary"), std::string::npos);
  EXPECT_NE(read_error(q, "POTMAP\r\n1234").find("not a potmap dictionary"), std::string::npos);

  b = bytes;
  put_u32_at(b, 8, 2);
  EXPECT_NE(read_error(q, b).find("byte offset 8: unsupported format version 2"),
            std::string::npos);
  b = bytes;
  put_u32_at(b, 12, 4);
  EXPECT_NE(read_error(q, b).find("byte offset 12: dimension 4"), std::string::npos);

  b = bytes;
  b[70] ^= 1;
  EXPECT_NE(read_error(q, b).find("checksum mismatch"), std::string::npos);

  b = bytes;
  put_f64_at(b, 16, std::nan(""));
  fix_crc(b);
  EXPECT_NE(read_error(q, b).find("byte offset 16: scale = nan"), std::string::npos);
  b = bytes;
  put_f64_at(b, 24, -3);
  fix_crc(b);
  EXPECT_NE(read_error(q, b).find("byte offset 24: max_range = -3: must be > 0"),
            std::string::npos);
  b = bytes;
  put_u32_at(b, 32, 0);
  fix_crc(b);
  EXPECT_NE(read_error(q, b).find("byte offset 32: sectors 0"), std::string::npos);
  b = bytes;
  put_u64_at(b, 40, std::uint64_t(1) << 60);
  fix_crc(b);
  EXPECT_NE(read_error(q, b).find("byte offset 40: atom count 1152921504606846976"),
            std::string::npos);
  b = bytes;
  put_u64_at(b, 48, bytes.size() + 8);
  EXPECT_NE(read_error(q, b).find("(truncated)"), std::string::npos);
}

TEST(DictionaryIo, BadAtomFieldsNameAtomOffsetAndValue) {
  const std::string dir = test::temp_dir("dict_io_atom");
  const std::string p = dir + "/d.potdict", q = dir + "/a.potdict";
  Dictionary d = random_dictionary(2, 1, 9);
  d.atoms[0].source = "";
  write_dictionary(d, p);
  const std::string bytes = potmap::test::file_bytes(p);
  const std::size_t atom = 64;          // first record
  const std::size_t hits = atom + 112;  // no source text
  const std::size_t nh = d.atoms[0].sector.num_hits(), nf = d.atoms[0].sector.num_free();
  const std::size_t kpos = hits + 8 * 2 * (nh + nf);  // kernel positions
  const std::size_t nk = d.atoms[0].kernels.size();
  const std::size_t gamma = kpos + 8 * 2 * nk;

  std::string b = bytes;
  put_f64_at(b, hits + 8, std::numeric_limits<double>::infinity());
  fix_crc(b);
  EXPECT_NE(read_error(q, b).find("byte offset " + std::to_string(hits + 8) +
                                  ": atom 0 hits[0][1] = inf: value is not finite"),
            std::string::npos)
      << read_error(q, b);

  b = bytes;
  put_f64_at(b, gamma, -0.5);
  fix_crc(b);
  EXPECT_NE(read_error(q, b).find("atom 0 kernel gamma[0] = -0.5: gamma must be > 0"),
            std::string::npos)
      << read_error(q, b);

  b = bytes;
  put_u32_at(b, atom, 7);  // sectors is 7: index 7 is out of range
  fix_crc(b);
  EXPECT_NE(read_error(q, b).find("byte offset 64: atom 0 sector index 7 outside [0, 7)"),
            std::string::npos);

  b = bytes;
  put_f64_at(b, atom + 56, 0.5);
  fix_crc(b);
  EXPECT_NE(read_error(q, b).find("atom 0 scale 0.5 differs"), std::string::npos);

  // A hit count that runs past the end is caught before anything is allocated.
  b = bytes;
  put_u64_at(b, atom + 80, std::uint64_t(1) << 61);
  fix_crc(b);
  EXPECT_NE(read_error(q, b).find("atom 0 hits: 2305843009213693952 x 2 values do not fit"),
            std::string::npos)
      << read_error(q, b);
  // One hit too many: the arrays no longer line up with the file.
  b = bytes;
  put_u64_at(b, atom + 80, nh + 1);
  fix_crc(b);
  EXPECT_NE(read_error(q, b).find("truncated"), std::string::npos) << read_error(q, b);
  // Bytes between the last atom and the checksum (size field and checksum made consistent).
  b = bytes;
  b.insert(b.size() - 4, 8, '\0');
  put_u64_at(b, 48, b.size());
  fix_crc(b);
  EXPECT_NE(read_error(q, b).find("8 unexpected bytes after the last atom"), std::string::npos)
      << read_error(q, b);
}

TEST(DictionaryIo, WriterRefusesInconsistentDictionaries) {
  const std::string p = test::temp_dir("dict_io_write") + "/w.potdict";
  Dictionary d = random_dictionary(2, 3, 1);
  d.atoms[1].sector.hits.push_back(0.5);  // not a multiple of dim
  EXPECT_THROW(write_dictionary(d, p), ArgumentError);
  d = random_dictionary(2, 3, 1);
  d.atoms[0].sector.free[0] = std::nan("");
  EXPECT_THROW(write_dictionary(d, p), ArgumentError);
  d = random_dictionary(2, 3, 1);
  d.atoms[0].kernels.has_bias = true;
  EXPECT_THROW(write_dictionary(d, p), ArgumentError);
  d = random_dictionary(2, 3, 1);
  d.atoms[0].sector.scale *= 2;
  EXPECT_THROW(write_dictionary(d, p), ArgumentError);
  d = random_dictionary(2, 3, 1);
  d.atoms[0].sector.dim = 3;
  EXPECT_THROW(write_dictionary(d, p), ArgumentError);
  EXPECT_FALSE(std::filesystem::exists(p));
}
