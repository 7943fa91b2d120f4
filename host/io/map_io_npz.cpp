// Kernel maps as NumPy archives, in the layout of the paper's authors (see map_io.hpp).
#include <cmath>
#include <sstream>

#include "io/npz.hpp"
#include "io/text_io.hpp"
#include "map/map_checks.hpp"
#include "potmap/error.hpp"
#include "potmap/io/map_io.hpp"

namespace potmap {

namespace {

using detail::MapField;

const npy::Array& require(const std::map<std::string, npy::Array>& arrays, const std::string& key,
                          const std::string& path) {
  auto it = arrays.find(key);
  if (it != arrays.end()) return it->second;
  std::string have;
  for (const auto& [k, a] : arrays) have += (have.empty() ? "" : ", ") + k;
  throw InputError(path + ": missing array '" + key + ".npy' (the archive holds: " +
                   (have.empty() ? std::string("no arrays") : have) + ")");
}

// A per-kernel vector may be stored as (M,), (M, 1) or (1, M): the authors' code wrote both
// column and row vectors.
std::vector<double> kernel_vector(const npy::Array& a, const std::string& key, std::size_t m,
                                  MapField field, const std::string& path) {
  const auto& s = a.shape;
  const bool ok = (s.size() == 1 && s[0] == m) ||
                  (s.size() == 2 && ((s[0] == m && s[1] == 1) || (s[0] == 1 && s[1] == m)));
  if (!ok) {
    std::ostringstream msg;
    msg << path << ": " << key << ".npy: shape " << a.shape_string() << " does not match " << m
        << " kernels of qhinge_mean.npy (expected (" << m << ",), (" << m << ", 1) or (1, " << m
        << "))";
    throw InputError(msg.str());
  }
  std::vector<double> v = a.to_double();
  for (std::size_t i = 0; i < v.size(); ++i)
    if (const char* why = detail::map_value_problem(field, v[i]))
      throw InputError(path + ": " + key + ".npy[" + std::to_string(i) +
                       "] = " + detail::format_double(v[i]) + ": " + why);
  return v;
}

double scalar(const npy::Array& a, const std::string& key, MapField field,
              const std::string& path) {
  if (a.count() != 1 || a.shape.size() > 2)
    throw InputError(path + ": " + key + ".npy: shape " + a.shape_string() +
                     " is not a single value");
  const double v = a.to_double()[0];
  if (const char* why = detail::map_value_problem(field, v))
    throw InputError(path + ": " + key + ".npy = " + detail::format_double(v) + ": " + why);
  return v;
}

}  // namespace

KernelMap read_map_npz(const std::string& path) {
  const auto arrays = npz::read(path);
  const npy::Array& h = require(arrays, "qhinge_mean", path);
  const npy::Array& g = require(arrays, "qgamma_mean_forward", path);
  const npy::Array& wm = require(arrays, "qw_mean", path);
  const npy::Array& wv = require(arrays, "qw_var", path);
  if (h.shape.size() != 2 || (h.shape[1] != 2 && h.shape[1] != 3))
    throw InputError(path + ": qhinge_mean.npy: shape " + h.shape_string() +
                     ": expected (M, 2) or (M, 3) kernel positions");
  KernelMap map;
  map.dim = static_cast<int>(h.shape[1]);
  const std::size_t m = h.shape[0];
  map.position = h.to_double();
  for (std::size_t i = 0; i < map.position.size(); ++i)
    if (const char* why = detail::map_value_problem(MapField::position, map.position[i]))
      throw InputError(path + ": qhinge_mean.npy[" + std::to_string(i / map.dim) + ", " +
                       std::to_string(i % map.dim) +
                       "] = " + detail::format_double(map.position[i]) + ": " + why);
  map.gamma = kernel_vector(g, "qgamma_mean_forward", m, MapField::gamma, path);
  map.w_mean = kernel_vector(wm, "qw_mean", m, MapField::w_mean, path);
  map.w_var = kernel_vector(wv, "qw_var", m, MapField::w_var, path);
  const auto bm = arrays.find("bias_mean");
  const auto bv = arrays.find("bias_var");
  if ((bm == arrays.end()) != (bv == arrays.end()))
    throw InputError(path + ": '" + (bm == arrays.end() ? "bias_var" : "bias_mean") +
                     ".npy' without '" + (bm == arrays.end() ? "bias_mean" : "bias_var") +
                     ".npy': a bias needs both");
  if (bm != arrays.end()) {
    map.has_bias = true;
    map.bias_mean = scalar(bm->second, "bias_mean", MapField::bias_mean, path);
    map.bias_var = scalar(bv->second, "bias_var", MapField::bias_var, path);
  }
  const auto cut = arrays.find("cutoff_tau");
  if (cut != arrays.end())
    map.cutoff_tau = scalar(cut->second, "cutoff_tau", MapField::cutoff_tau, path);
  return map;
}

void write_map_npz(const KernelMap& map, const std::string& path) {
  map.validate(path);
  const std::size_t m = map.size();
  const std::size_t d = static_cast<std::size_t>(map.dim);
  std::vector<std::pair<std::string, npy::Array>> arrays;
  // float64 throughout (the authors stored float32 for all but positions): exact round trips.
  arrays.emplace_back("qhinge_mean", npy::Array::from_doubles(map.position, {m, d}));
  arrays.emplace_back("qgamma_mean_forward", npy::Array::from_doubles(map.gamma, {1, m}));
  arrays.emplace_back("qw_mean", npy::Array::from_doubles(map.w_mean, {m, 1}));
  arrays.emplace_back("qw_var", npy::Array::from_doubles(map.w_var, {m, 1}));
  if (map.has_bias) {
    arrays.emplace_back("bias_mean", npy::Array::from_doubles({map.bias_mean}, {}));
    arrays.emplace_back("bias_var", npy::Array::from_doubles({map.bias_var}, {}));
  }
  if (std::isfinite(map.cutoff_tau))
    arrays.emplace_back("cutoff_tau", npy::Array::from_doubles({map.cutoff_tau}, {}));
  npz::write(path, arrays);
}

}  // namespace potmap
