// Kernel maps, their evaluation and rasters (include/potmap/map/), and the scores.

#include <pybind11/stl.h>

#include <cmath>
#include <cstring>
#include <mutex>
#include <optional>
#include <utility>

#include "bindings.hpp"
#include "convert.hpp"
#include "potmap/map/evaluate.hpp"
#include "potmap/map/height_band.hpp"
#include "potmap/map/metrics.hpp"
#include "potmap/map/raster.hpp"
#include "potmap/map/synthetic.hpp"
#include "raster_window.hpp"
#include "values.hpp"

namespace potmap::python {

namespace py = pybind11;
using namespace pybind11::literals;

namespace {

KernelMap make_map(py::handle positions, py::handle gamma, py::handle w_mean, py::handle w_var,
                   py::object bias) {
  Points p = points_arg(positions, 0, "positions");
  KernelMap map;
  map.dim = p.array.ndim() == 2 ? static_cast<int>(p.array.shape(1)) : 2;
  map.position.assign(p.data, p.data + p.n * map.dim);
  long n = static_cast<long>(p.n);
  map.gamma = doubles_arg(gamma, n, "gamma");
  map.w_mean = doubles_arg(w_mean, n, "w_mean");
  map.w_var = doubles_arg(w_var, n, "w_var");
  if (!bias.is_none()) {
    auto b = bias.cast<std::pair<double, double>>();
    map.has_bias = true;
    map.bias_mean = b.first;
    map.bias_var = b.second;
  }
  map.validate();
  return map;
}

// The raster window (row 0 = the top, largest y) as a grid: cell (i, j) of the grid is pixel
// (height - 1 - j, i), as rasterize() and `potmap raster` lay it out.
GridSpec window_grid(int dim, const RasterSpec& spec) {
  spec.validate();
  GridSpec g;
  g.dim = dim;
  g.origin[0] = spec.xmin;
  g.origin[1] = spec.ymin;
  g.origin[2] = spec.z - 0.5 * spec.resolution;
  g.resolution = spec.resolution;
  g.count[0] = spec.width();
  g.count[1] = spec.height();
  g.count[2] = 1;
  return g;
}

// Flips grid rows (y up) into picture rows (y down).
py::array_t<float> picture(const std::vector<float>& grid, std::size_t w, std::size_t h) {
  py::array_t<float> out({static_cast<py::ssize_t>(h), static_cast<py::ssize_t>(w)});
  float* o = out.mutable_data();
  for (std::size_t r = 0; r < h; ++r) {
    std::memcpy(o + r * w, grid.data() + (h - 1 - r) * w, w * sizeof(float));
  }
  return out;
}

EvalOptions eval_options(double tau) {
  EvalOptions o;
  o.tau = tau;
  return o;
}

// MapEvaluator is not thread-safe, and the GIL is released around it: its own lock makes two
// Python threads sharing one evaluator take turns instead of racing.
struct Evaluator {
  Evaluator(Context& ctx, const KernelMap& map, double tau)
      : ev(ctx, map, eval_options(tau)), band_step(default_band_step(map)) {}
  MapEvaluator ev;
  double band_step;  // the map's default height-band step
  std::mutex mu;
};

Values evaluate_points(Evaluator& e, py::handle points) {
  MapEvaluator& ev = e.ev;
  Points p = points_arg(points, ev.dim(), "points");
  auto n = static_cast<py::ssize_t>(p.n);
  py::array_t<float> prob(n), mean(n), var(n);
  float *pp = prob.mutable_data(), *pm = mean.mutable_data(), *pv = var.mutable_data();
  {
    py::gil_scoped_release release;
    std::lock_guard<std::mutex> lock(e.mu);
    ev.evaluate(p.data, p.n, pm, pv, pp);
  }
  return {prob, mean, var};
}

Values raster_values(Evaluator& e, const std::vector<double>& bounds, double res, double z,
                     const Band& band, double band_step) {
  const RasterSpec spec = window(bounds, res, z, band, band_step);
  GridSpec g = window_grid(e.ev.dim(), spec);
  MapValues v;
  {
    py::gil_scoped_release release;
    std::lock_guard<std::mutex> lock(e.mu);
    if (spec.has_band()) {
      const std::vector<double> levels =
          height_band_levels(spec.band_lo, spec.band_hi, band_step > 0 ? band_step : e.band_step);
      const std::size_t n = g.count[0] * g.count[1];
      v.mean.resize(n);
      v.var.resize(n);
      v.prob.resize(n);
      e.ev.evaluate_band_max(g, levels, v.mean.data(), v.var.data(), v.prob.data());
    } else {
      v = e.ev.evaluate_grid(g);
    }
  }
  return {picture(v.prob, g.count[0], g.count[1]), picture(v.mean, g.count[0], g.count[1]),
          picture(v.var, g.count[0], g.count[1])};
}

// A per-kernel array of the map as a property: read as a copy, assigned whole (M values).
void kernel_property(py::class_<KernelMap>& cls, const char* name,
                     std::vector<double> KernelMap::*member, const char* doc) {
  cls.def_property(
      name,
      [member](const KernelMap& k) {
        return to_array(k.*member, {static_cast<py::ssize_t>(k.size())});
      },
      [member, name](KernelMap& k, py::handle v) {
        k.*member = doubles_arg(v, static_cast<long>(k.size()), name);
      },
      doc);
}

Scores score_any(py::handle prob, py::handle labels) {
  std::vector<std::uint8_t> l = labels_arg(labels, -1, "labels");
  std::vector<double> p = doubles_arg(prob, static_cast<long>(l.size()), "prob");
  py::gil_scoped_release release;
  return score(p, l);
}

// The evaluations of a KernelMap: on a device, exactly on the CPU, and on a raster window.
void define_kernel_map_evaluation(py::class_<KernelMap>& kernel_map) {
  kernel_map
      .def(
          "evaluate",
          [](KernelMap k, py::handle points, Context& ctx, double tau) {
            std::unique_ptr<Evaluator> ev;
            {
              py::gil_scoped_release release;
              ev = std::make_unique<Evaluator>(ctx, k, tau);
            }
            return evaluate_points(*ev, points);
          },
          "points"_a, "ctx"_a, "tau"_a = kDefaultCutoffTau,
          "Probability, mean and variance (float32 arrays of n) at points ((n, dim) float64 or\n"
          "float32, metres) on the device of ctx. tau: cut-off exponent (default 18: terms with\n"
          "gamma d^2 > 18 are dropped, each below 1.5e-8 of its weight). Uploads the map on\n"
          "every call: use Evaluator for repeated queries.")
      .def(
          "evaluate_exact",
          [](KernelMap k, py::handle points) {
            Points p = points_arg(points, k.dim, "points");
            MapValuesExact v;
            {
              py::gil_scoped_release release;
              k.validate();
              v = evaluate_exact(k, p.data, p.n);
            }
            auto n = static_cast<py::ssize_t>(p.n);
            return Values{to_array(v.prob, {n}), to_array(v.mean, {n}), to_array(v.var, {n})};
          },
          "points"_a,
          "The exact reference: a dense double-precision sum over every kernel (no cut-off),\n"
          "on the CPU. Probability, mean and variance as float64 arrays of n.")
      .def(
          "raster",
          [](KernelMap k, const std::vector<double>& bounds, double res, Context& ctx, double z,
             double tau, const Band& band, double band_step) {
            std::unique_ptr<Evaluator> ev;
            {
              py::gil_scoped_release release;
              ev = std::make_unique<Evaluator>(ctx, k, tau);
            }
            return raster_values(*ev, bounds, res, z, band, band_step);
          },
          "bounds"_a, "res"_a, "ctx"_a, "z"_a = 0.0, "tau"_a = kDefaultCutoffTau,
          "band"_a = py::none(), "band_step"_a = 0.0,
          "Probability, mean and variance on the window bounds = (xmin, xmax, ymin, ymax)\n"
          "(metres) with cells res metres wide: float32 arrays of shape (height, width),\n"
          "row 0 the top (largest y), as `potmap raster` writes its .npy files (show with\n"
          "imshow(origin='upper')). Cell (r, c) is centred at x = xmin + (c + 0.5) res,\n"
          "y = ymin + (height - 1 - r + 0.5) res; width = ceil((xmax - xmin) / res).\n"
          "z: height of the slice of a 3D map, metres (default 0).\n"
          "band: (z_lo, z_hi) metres, 3D maps: instead of the slice, each cell holds the largest\n"
          "probability over those heights and the mean and variance where it is reached;\n"
          "band_step: largest spacing of the heights sampled, both ends included (default 0:\n"
          "the standard deviation of the map's narrowest kernel).");
}

// KernelMap: kernels read and assigned as whole arrays.
void bind_kernel_map(py::module_& m) {
  py::class_<KernelMap> kernel_map(
      m, "KernelMap",
      "A continuous occupancy map: M squared-exponential kernels with Gaussian\n"
      "weights, plus an optional bias weight (SPEC section 2):\n"
      "  phi_m(x) = exp(-gamma_m |x - h_m|^2)\n"
      "  mu(x) = b_mean + sum w_mean_m phi_m(x)\n"
      "  s2(x) = b_var + sum w_var_m phi_m(x)^2\n"
      "  p(x) = sigmoid(mu / sqrt(1 + pi s2 / 8))\n"
      "Array properties return copies (float64); assign whole arrays to change them.");
  kernel_map
      .def(py::init(&make_map), "positions"_a, "gamma"_a, "w_mean"_a, "w_var"_a,
           "bias"_a = py::none(),
           "positions: (M, 2) or (M, 3) kernel centres, metres; gamma: (M,) widths, 1/m^2, > 0;\n"
           "w_mean: (M,) weight means (logit units); w_var: (M,) weight variances, >= 0;\n"
           "bias: (mean, variance) of the bias weight, or None (default: no bias).\n"
           "Raises ArgumentError naming the first bad kernel and value.")
      .def(py::init([](int dim) {
             if (dim != 2 && dim != 3) throw py::value_error("dim must be 2 or 3");
             KernelMap k;
             k.dim = dim;
             return k;
           }),
           "dim"_a = 2, "An empty map of dimension dim (2 or 3; default 2).")
      .def_readonly("dim", &KernelMap::dim, "2 or 3")
      .def("__len__", &KernelMap::size)
      .def_property(
          "positions", [](const KernelMap& k) { return points_array(k.position, k.dim); },
          [](KernelMap& k, py::handle v) {
            Points p = points_arg(v, k.dim, "positions");
            if (p.n != k.size())
              throw py::value_error("positions: expected " + std::to_string(k.size()) + " rows");
            k.position.assign(p.data, p.data + p.n * k.dim);
          },
          "(M, dim) kernel centres, metres")
      .def_property(
          "bias",
          [](const KernelMap& k) -> py::object {
            if (!k.has_bias) return py::none();
            return py::make_tuple(k.bias_mean, k.bias_var);
          },
          [](KernelMap& k, py::object b) {
            k.has_bias = !b.is_none();
            auto v =
                k.has_bias ? b.cast<std::pair<double, double>>() : std::pair<double, double>{0, 0};
            k.bias_mean = v.first;
            k.bias_var = v.second;
          },
          "(mean, variance) of the bias weight, or None")
      .def_readwrite("cutoff_tau", &KernelMap::cutoff_tau,
                     "The cut-off exponent the map was learned with (> 0): its learner never\n"
                     "used terms with gamma d^2 beyond it, and the evaluators cut there when it\n"
                     "is below their own tau. inf (the default): the evaluators' own tau (18).\n"
                     "A drive's map carries its learner's feature cut-off (4.5); evaluate_exact\n"
                     "sums every term either way.")
      .def("validate", &KernelMap::validate, "source"_a = "",
           "Raises ArgumentError naming the first kernel and value that breaks the model.")
      .def(
          "bounds",
          [](const KernelMap& k) {
            double lo[3], hi[3];
            k.bounds(lo, hi);
            return py::make_tuple(std::vector<double>(lo, lo + k.dim),
                                  std::vector<double>(hi, hi + k.dim));
          },
          "(lo, hi): axis-aligned bounds of the kernel positions, metres (zeros when empty).");
  define_kernel_map_evaluation(kernel_map);

  kernel_property(kernel_map, "gamma", &KernelMap::gamma, "(M,) kernel widths, 1/m^2");
  kernel_property(kernel_map, "w_mean", &KernelMap::w_mean, "(M,) weight means");
  kernel_property(kernel_map, "w_var", &KernelMap::w_var, "(M,) weight variances");
}

// Evaluator, and rasterize() to files.
void bind_map_evaluator(py::module_& m) {
  py::class_<Evaluator>(m, "Evaluator",
                        "A map uploaded once to a device, evaluated any number of times.\n"
                        "Keeps its Context alive. Threads sharing one take turns.")
      .def(py::init([](Context& ctx, KernelMap map, double tau) {
             py::gil_scoped_release release;
             return std::make_unique<Evaluator>(ctx, map, tau);
           }),
           "ctx"_a, "map"_a, "tau"_a = kDefaultCutoffTau, py::keep_alive<1, 2>(),
           "ctx: the device; map: a KernelMap (validated, copied to the device);\n"
           "tau: cut-off exponent (default 18; a map learned with a smaller cutoff_tau\n"
           "is evaluated at that).")
      .def_property_readonly("dim", [](const Evaluator& e) { return e.ev.dim(); })
      .def("evaluate", &evaluate_points, "points"_a,
           "Probability, mean and variance (float32 arrays of n) at points, (n, dim) float64 or\n"
           "float32 in metres. A float64 C-contiguous array is read in place (no copy).\n"
           "Non-finite coordinates give NaN.")
      .def("raster", &raster_values, "bounds"_a, "res"_a, "z"_a = 0.0, "band"_a = py::none(),
           "band_step"_a = 0.0,
           "As KernelMap.raster: (height, width) float32 arrays, row 0 the top; band =\n"
           "(z_lo, z_hi) for a 3D map's height-band maximum.")
      .def_property_readonly(
          "last_pairs",
          [](Evaluator& e) {
            std::lock_guard<std::mutex> lock(e.mu);
            return e.ev.last_pairs();
          },
          "kernel-query pairs visited by the last call (work done)");

  m.def(
      "rasterize",
      [](Context& ctx, KernelMap map, const std::vector<double>& bounds, double res,
         const std::string& out_prefix, double z, bool png, bool npy, std::size_t band_cells,
         const Band& band, double band_step) {
        RasterOptions o;
        o.write_png = png;
        o.write_npy = npy;
        o.max_band_cells = band_cells;
        RasterSpec spec = window(bounds, res, z, band, band_step);
        RasterSummary s;
        {
          py::gil_scoped_release release;
          s = rasterize(ctx, map, spec, out_prefix, o);
        }
        return py::dict("width"_a = s.width, "height"_a = s.height, "cells"_a = s.cells,
                        "bands"_a = s.bands, "seconds"_a = s.seconds, "prob_min"_a = s.prob_min,
                        "prob_max"_a = s.prob_max, "var_min"_a = s.var_min, "var_max"_a = s.var_max,
                        "levels"_a = s.levels, "files"_a = s.files);
      },
      "ctx"_a, "map"_a, "bounds"_a, "res"_a, "out_prefix"_a, "z"_a = 0.0, "png"_a = true,
      "npy"_a = true, "band_cells"_a = std::size_t(1) << 22, "band"_a = py::none(),
      "band_step"_a = 0.0,
      "Writes PREFIX_prob.png, PREFIX_var.png (8-bit indexed colour: viridis, magma on\n"
      "s2 / (1 + s2)) and PREFIX_prob.npy, PREFIX_var.npy (float32, row 0 the top), as\n"
      "`potmap raster`, streamed\n"
      "in bands of at most band_cells cells (default 4 Mi, about 80 MB). Files appear only when\n"
      "all are complete. band = (z_lo, z_hi) metres, 3D maps: the height band's maximum\n"
      "probability and the variance where it is reached, instead of the slice at z (heights\n"
      "at most band_step apart, both ends included; 0: the map's narrowest kernel's deviation).\n"
      "Returns a dict: width, height, cells, bands, seconds, prob_min/max, var_min/max,\n"
      "levels (heights of the band; 0 for a slice), files.");
}

// The probit probability and the scores of predictions.
void bind_map_scores(py::module_& m) {
  m.def("probit_probability", &probit_probability, "mean"_a, "var"_a,
        "sigmoid(mean / sqrt(1 + pi var / 8)).");

  py::class_<Scores>(m, "Scores", "Accuracy, ROC AUC and mean NLL of a set of predictions.")
      .def_readonly("acc", &Scores::acc, "fraction with (p >= 0.5) == label")
      .def_readonly("auc", &Scores::auc, "ROC AUC, ties count one half; NaN with one class")
      .def_readonly("nll", &Scores::nll, "mean -log p(label), p clipped to [1e-6, 1 - 1e-6], nats")
      .def_readonly("n", &Scores::n, "points scored")
      .def("__repr__", [](const Scores& s) {
        return "Scores(acc=" + std::to_string(s.acc) + ", auc=" + std::to_string(s.auc) +
               ", nll=" + std::to_string(s.nll) + ", n=" + std::to_string(s.n) + ")";
      });
  m.def("score", &score_any, "prob"_a, "labels"_a,
        "Scores of occupancy probabilities prob ((n,) floats in [0, 1]) against labels ((n,),\n"
        "1 occupied, 0 free; bool or integer): ACC (p >= 0.5 counts as occupied), AUC\n"
        "(Mann-Whitney, ties one half) and mean NLL (p clipped to [1e-6, 1 - 1e-6]). Empty\n"
        "input: NaN. ArgumentError for NaN or out-of-range probabilities.");
}

// The built-in synthetic scene.
void bind_map_synthetic(py::module_& m) {
  py::class_<SyntheticScene>(m, "SyntheticScene", "A built-in 2D yard with a hand-fitted map.")
      .def_readonly("map", &SyntheticScene::map, "the KernelMap")
      .def_readonly("test", &SyntheticScene::test, "labelled test points (LabelledPoints)")
      .def_property_readonly(
          "bounds",
          [](const SyntheticScene& s) { return std::vector<double>(s.bounds, s.bounds + 4); },
          "(xmin, xmax, ymin, ymax), metres");
  m.def("synthetic_scene", &make_synthetic_scene, "seed"_a = 1, "spacing"_a = 0.5,
        "test_points"_a = 2000,
        "A deterministic scene: kernels spacing metres apart (default 0.5), test_points\n"
        "labelled points (default 2000), seed for the obstacles and points (default 1).");
}

}  // namespace

void bind_map(py::module_& m) {
  bind_values(m);

  bind_kernel_map(m);
  bind_map_evaluator(m);
  bind_map_scores(m);
  bind_map_synthetic(m);
}

}  // namespace potmap::python
