// NumPy .npz labelled datasets as the paper's authors stored them (X: t, x, y[, z]; Y: labels).

#include <cmath>
#include <cstring>
#include <memory>
#include <string>
#include <vector>

#include "io/npz.hpp"
#include "potmap/data/scan.hpp"
#include "potmap/error.hpp"

namespace potmap {

// The archive and its arrays go through the map reader's npz/npy code (host/io/npz.hpp), which
// checks every size a file claims before allocating.
LabelledPoints read_npz_labelled(const std::string& path) {
  const std::map<std::string, npy::Array> arrays = npz::read(path);
  auto get = [&](const char* key) -> const npy::Array& {
    auto it = arrays.find(key);
    if (it == arrays.end())
      throw InputError(path + ": byte 0: no member " + std::string(key) +
                       ".npy in the archive (a labelled dataset holds X.npy and Y.npy)");
    return it->second;
  };
  const npy::Array& xa = get("X");
  const npy::Array& ya = get("Y");
  if (xa.shape.size() != 2 || (xa.shape[1] != 3 && xa.shape[1] != 4))
    throw InputError(path + ": X.npy: byte 0: shape must be (N, 3) or (N, 4), got " +
                     xa.shape_string());
  const std::size_t n = xa.shape[0], c = xa.shape[1];
  const std::vector<double> X = xa.to_double(), Y = ya.to_double();
  if (Y.size() != n)
    throw InputError(path + ": Y.npy: byte 0: " + std::to_string(Y.size()) + " labels for " +
                     std::to_string(n) + " rows of X");
  LabelledPoints lp;
  lp.dim = static_cast<int>(c) - 1;
  for (std::size_t i = 0; i < n; ++i) {
    const double* r = &X[i * c];
    bool ok = std::isfinite(Y[i]);
    for (std::size_t k = 0; k < c; ++k) ok = ok && std::isfinite(r[k]);
    if (!ok) continue;  // NaN rows are dropped at the door, as in every reader
    lp.scan.push_back(static_cast<std::int64_t>(r[0]));
    lp.position.insert(lp.position.end(), r + 1, r + c);
    lp.label.push_back(Y[i] > 0.5 ? 1 : 0);
  }
  return lp;
}

}  // namespace potmap
