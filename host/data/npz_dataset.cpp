// Minimal .npz reader for labelled datasets (X: t, x, y[, z]; Y: labels).
// TODO(lead): share the npy header parsing with the io branch's host/npy.* once merged.
#include <zip.h>

#include <cmath>
#include <cstring>
#include <memory>
#include <string>
#include <vector>

#include "potmap/error.hpp"
#include "potmap/scan.hpp"

namespace potmap {

namespace {

struct Array {
  std::vector<double> v;
  std::vector<std::size_t> shape;
};

[[noreturn]] void bad(const std::string& path, const std::string& member, std::size_t off,
                      const std::string& why) {
  throw InputError(path + ": " + member + ": byte " + std::to_string(off) + ": " + why);
}

Array parse_npy(const std::string& path, const std::string& m, const std::string& b) {
  if (b.size() < 10 || std::memcmp(b.data(), "\x93NUMPY", 6) != 0)
    bad(path, m, 0, "not a .npy member (magic bytes)");
  const int major = static_cast<unsigned char>(b[6]);
  std::size_t hlen, hoff;
  if (major == 1) {
    hlen = static_cast<unsigned char>(b[8]) | static_cast<unsigned char>(b[9]) << 8;
    hoff = 10;
  } else {
    if (b.size() < 12) bad(path, m, 8, "truncated header");
    hlen = 0;
    for (int k = 0; k < 4; ++k) hlen |= std::size_t(static_cast<unsigned char>(b[8 + k])) << 8 * k;
    hoff = 12;
  }
  if (hoff + hlen > b.size()) bad(path, m, hoff, "header length " + std::to_string(hlen));
  const std::string h = b.substr(hoff, hlen);
  auto field = [&](const char* key) {
    const std::size_t k = h.find(key);
    if (k == std::string::npos) bad(path, m, hoff, std::string("header lacks ") + key);
    return k + std::strlen(key);
  };
  std::size_t k = field("'descr':");
  const std::size_t q1 = h.find('\'', k), q2 = q1 == std::string::npos ? q1 : h.find('\'', q1 + 1);
  if (q2 == std::string::npos) bad(path, m, hoff + k, "bad descr");
  const std::string descr = h.substr(q1 + 1, q2 - q1 - 1);
  if (h.find("'fortran_order': True") != std::string::npos)
    bad(path, m, hoff, "fortran_order True is not supported");
  k = field("'shape':");
  const std::size_t p1 = h.find('(', k), p2 = p1 == std::string::npos ? p1 : h.find(')', p1);
  if (p2 == std::string::npos) bad(path, m, hoff + k, "bad shape");
  Array a;
  std::size_t count = 1;
  for (std::size_t i = p1 + 1; i < p2;) {
    while (i < p2 && (h[i] == ' ' || h[i] == ',')) ++i;
    if (i >= p2) break;
    std::size_t n = 0, j = i;
    while (j < p2 && h[j] >= '0' && h[j] <= '9') {
      n = n * 10 + (h[j] - '0');
      if (n > (std::size_t(1) << 40)) bad(path, m, hoff + j, "dimension too large");
      ++j;
    }
    if (j == i) bad(path, m, hoff + i, std::string("bad shape character '") + h[i] + "'");
    a.shape.push_back(n);
    count *= n;
    if (count > (std::size_t(1) << 40)) bad(path, m, hoff + j, "array too large");
    i = j;
  }
  if (descr.size() < 3 || descr[0] == '>') bad(path, m, hoff, "unsupported dtype '" + descr + "'");
  const char kind = descr[1];
  const std::size_t w = std::strtoul(descr.c_str() + 2, nullptr, 10);
  const std::size_t data = hoff + hlen;
  if ((b.size() - data) / (w ? w : 1) < count || w == 0)
    bad(path, m, b.size(), "data holds fewer than " + std::to_string(count) + " elements");
  a.v.resize(count);
  const char* p = b.data() + data;
  for (std::size_t i = 0; i < count; ++i, p += w) {
    if (kind == 'f' && w == 8) {
      double x;
      std::memcpy(&x, p, 8);
      a.v[i] = x;
    } else if (kind == 'f' && w == 4) {
      float x;
      std::memcpy(&x, p, 4);
      a.v[i] = x;
    } else if (kind == 'i' && w == 8) {
      std::int64_t x;
      std::memcpy(&x, p, 8);
      a.v[i] = double(x);
    } else if (kind == 'i' && w == 4) {
      std::int32_t x;
      std::memcpy(&x, p, 4);
      a.v[i] = x;
    } else if ((kind == 'u' || kind == 'b') && w == 1) {
      a.v[i] = static_cast<unsigned char>(*p);
    } else
      bad(path, m, hoff, "unsupported dtype '" + descr + "'");
  }
  return a;
}

std::string member(zip_t* z, const std::string& path, const char* name) {
  zip_stat_t st;
  if (zip_stat(z, name, 0, &st) != 0 || !(st.valid & ZIP_STAT_SIZE))
    throw InputError(path + ": byte 0: no member '" + name + "'");
  if (st.size > (std::uint64_t(1) << 32)) throw InputError(path + ": member too large: " + name);
  std::unique_ptr<zip_file_t, int (*)(zip_file_t*)> f(zip_fopen(z, name, 0), zip_fclose);
  if (!f) throw InputError(path + ": cannot open member '" + std::string(name) + "'");
  std::string b(st.size, '\0');
  if (zip_fread(f.get(), b.data(), st.size) != static_cast<zip_int64_t>(st.size))
    throw InputError(path + ": member '" + std::string(name) + "' is corrupt");
  return b;
}

}  // namespace

LabelledPoints read_npz_labelled(const std::string& path) {
  int err = 0;
  std::unique_ptr<zip_t, void (*)(zip_t*)> z(zip_open(path.c_str(), ZIP_RDONLY, &err), zip_discard);
  if (!z)
    throw InputError(path + ": byte 0: not a readable .npz (zip error " + std::to_string(err) +
                     ")");
  const Array X = parse_npy(path, "X.npy", member(z.get(), path, "X.npy"));
  const Array Y = parse_npy(path, "Y.npy", member(z.get(), path, "Y.npy"));
  if (X.shape.size() != 2 || (X.shape[1] != 3 && X.shape[1] != 4))
    throw InputError(path + ": X.npy: byte 0: shape must be (N, 3) or (N, 4), columns: " +
                     std::to_string(X.shape.size() == 2 ? X.shape[1] : 0));
  const std::size_t n = X.shape[0], c = X.shape[1];
  if (Y.v.size() != n)
    throw InputError(path + ": Y.npy: byte 0: " + std::to_string(Y.v.size()) + " labels for " +
                     std::to_string(n) + " rows of X");
  LabelledPoints lp;
  lp.dim = static_cast<int>(c) - 1;
  for (std::size_t i = 0; i < n; ++i) {
    const double* r = &X.v[i * c];
    bool ok = std::isfinite(Y.v[i]);
    for (std::size_t k = 0; k < c; ++k) ok = ok && std::isfinite(r[k]);
    if (!ok) continue;  // NaN rows are dropped at the door, as in every reader
    lp.scan.push_back(static_cast<std::int64_t>(r[0]));
    lp.position.insert(lp.position.end(), r + 1, r + c);
    lp.label.push_back(Y.v[i] > 0.5 ? 1 : 0);
  }
  return lp;
}

}  // namespace potmap
