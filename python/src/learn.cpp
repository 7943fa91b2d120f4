// The learners: BHM (diagonal, on the device), the online joint BHM and ABHM
// (include/potmap/learn/).

#include <pybind11/functional.h>
#include <pybind11/stl.h>

#include <memory>
#include <mutex>
#include <type_traits>

#include "bindings.hpp"
#include "convert.hpp"
#include "potmap/learn/abhm.hpp"
#include "potmap/learn/bhm.hpp"
#include "potmap/learn/bhm_joint.hpp"

namespace potmap::python {

namespace py = pybind11;
using namespace pybind11::literals;

namespace {

// (lo, hi) of `dim` coordinates each into the library's 3-arrays.
void box_arg(const std::vector<double>& lo, const std::vector<double>& hi, int dim, double l[3],
             double h[3]) {
  if (static_cast<int>(lo.size()) != dim || static_cast<int>(hi.size()) != dim) {
    throw py::value_error("lo, hi: expected " + std::to_string(dim) + " coordinates each");
  }
  for (int d = 0; d < 3; ++d) {
    l[d] = d < dim ? lo[d] : 0;
    h[d] = d < dim ? hi[d] : 0;
  }
}

// The learner does not say its dimension; the binding keeps it to check query arrays.
// It is not thread-safe (not even its const members) and runs without the GIL: its own lock
// makes Python threads sharing one take turns.
struct PyJointBhm : JointBhm {
  PyJointBhm(int d, const JointBhmOptions& o) : JointBhm(d, o), dim(d) {}
  PyJointBhm(int d, const double lo[3], const double hi[3], const JointBhmOptions& o)
      : JointBhm(d, lo, hi, o), dim(d) {}
  int dim;
  std::unique_ptr<std::mutex> mu = std::make_unique<std::mutex>();
};

// A member of the learner run without the GIL and under its lock.
template <class R, class... A>
auto unlocked(R (JointBhm::*f)(A...)) {
  return [f](PyJointBhm& b, A... a) {
    py::gil_scoped_release release;
    std::lock_guard<std::mutex> lock(*b.mu);
    return (b.*f)(a...);
  };
}
template <class R, class... A>
auto unlocked(R (JointBhm::*f)(A...) const) {
  return [f](PyJointBhm& b, A... a) {
    py::gil_scoped_release release;
    std::lock_guard<std::mutex> lock(*b.mu);
    return std::decay_t<R>((b.*f)(a...));
  };
}

BhmOptions bhm_options(const py::kwargs& kw) {
  return options_from<BhmOptions>(kw, "BhmOptions");
}

// The diagonal BHM: its options, a grid prior and an update.
void bind_learn_bhm(py::module_& m) {
  py::class_<BhmOptions> bhm_opt(m, "BhmOptions", "EM settings of a BHM update.");
  bhm_opt
      .def(py::init([](const py::kwargs& kw) { return bhm_options(kw); }),
           "Keyword arguments set the fields.")
      .def_readwrite("em_iterations", &BhmOptions::em_iterations,
                     "E-steps per update (default 3); each but the last followed by an M-step")
      .def_readwrite("xi_init", &BhmOptions::xi_init,
                     "starting xi of every sample (> 0; default 1)")
      .def_readwrite("tau", &BhmOptions::tau, "kernel cut-off exponent (default 18)");
  add_fields_repr(bhm_opt);

  m.def(
      "bhm_grid_prior",
      [](const std::vector<double>& lo, const std::vector<double>& hi, double spacing, double gamma,
         double w_mean0, double w_var0, bool bias) {
        int dim = static_cast<int>(lo.size());
        double l[3], h[3];
        box_arg(lo, hi, dim, l, h);
        return bhm_grid_prior(dim, l, h, spacing, gamma, w_mean0, w_var0, bias);
      },
      "lo"_a, "hi"_a, "spacing"_a, "gamma"_a, "w_mean0"_a = 0.0, "w_var0"_a = 1e4, "bias"_a = false,
      "A BHM prior: kernels spacing metres apart over the box [lo, hi] (2 or 3 coordinates,\n"
      "metres), width gamma (1/m^2), weight mean w_mean0 (default 0) and variance w_var0\n"
      "(default 1e4, the authors'); bias adds a bias weight with the same prior.");
  m.def(
      "bhm_update",
      [](KernelMap map, const LabelledPoints& samples, Context* ctx, bool sequential,
         const py::kwargs& kw) {
        BhmOptions o = bhm_options(kw);
        py::gil_scoped_release release;
        if (sequential) {
          bhm_update_sequential(ctx, map, samples, o);
        } else if (ctx) {
          bhm_update(*ctx, map, samples, o);
        } else {
          bhm_update_reference(map, samples, o);
        }
        return map;
      },
      "prior"_a, "samples"_a, "ctx"_a = nullptr, "sequential"_a = false,
      "BHM (diagonal posterior, SPEC section 3): returns the posterior of `prior` (a\n"
      "KernelMap; positions and widths kept) given labelled samples. ctx: the device for the\n"
      "sums (default None: the double-precision CPU reference). sequential: scan by scan in\n"
      "increasing scan index, each posterior the next prior (online BHM). Keyword arguments:\n"
      "BhmOptions fields (em_iterations=3, xi_init=1, tau=18).");
}

// JointBhmOptions and JointBhmStats: how the joint BHM learns and what it reports.
void bind_learn_joint_bhm_options(py::module_& m) {
  py::class_<JointBhmOptions> jopt(m, "JointBhmOptions", "Settings of the online joint BHM.");
  jopt.def(py::init([](const py::kwargs& kw) {
        return options_from<JointBhmOptions>(kw, "JointBhmOptions");
      }))
      .def_readwrite("spacing", &JointBhmOptions::spacing,
                     "kernel grid spacing, metres (default 0.5)")
      .def_readwrite("gamma", &JointBhmOptions::gamma,
                     "kernel width, 1/m^2; 0 (default): -ln(neighbour_phi) / spacing^2")
      .def_readwrite("neighbour_phi", &JointBhmOptions::neighbour_phi,
                     "feature value one spacing from a centre when gamma is 0 (default 0.19)")
      .def_readwrite("prior_var", &JointBhmOptions::prior_var, "prior weight variance (default 10)")
      .def_readwrite("bias", &JointBhmOptions::bias, "a bias weight (default True)")
      .def_readwrite("em_iterations", &JointBhmOptions::em_iterations, "per scan (default 3)")
      .def_readwrite("tau", &JointBhmOptions::tau,
                     "feature cut-off exponent of the learner (default 6)")
      .def_readwrite("cg_tolerance", &JointBhmOptions::cg_tolerance,
                     "relative residual (default 1e-5)")
      .def_readwrite("cg_max_iterations", &JointBhmOptions::cg_max_iterations,
                     "per solve (default 300)")
      .def_readwrite("solve_margin", &JointBhmOptions::solve_margin,
                     "rings of kernels, spacings (default 4)")
      .def_readwrite("seeds_yield", &JointBhmOptions::seeds_yield,
                     "a seeded prior returns to the plain one when a sample reaches its kernel "
                     "(default True)")
      .def_readwrite("seeds_yield_fully", &JointBhmOptions::seeds_yield_fully,
                     "a seed yields, its mean too, when its kernel enters a scan's solve: "
                     "RePOT then equals BHM near the data (default True)")
      .def_readwrite("max_kernels", &JointBhmOptions::max_kernels,
                     "stored-kernel guard (default 2^26)")
      .def_readwrite("half_life", &JointBhmOptions::half_life,
                     "forgetting: the data's evidence halves every half_life seconds of sensor "
                     "time (set_time()); 0 (default): never")
      .def_property(
          "sums",
          [](const JointBhmOptions& o) {
            return o.sums == JointBhmSums::host     ? "host"
                   : o.sums == JointBhmSums::device ? "device"
                                                    : "automatic";
          },
          [](JointBhmOptions& o, const std::string& v) {
            if (v != "automatic" && v != "host" && v != "device")
              throw ArgumentError("sums must be 'automatic', 'host' or 'device', not '" + v + "'");
            o.sums = v == "host"     ? JointBhmSums::host
                     : v == "device" ? JointBhmSums::device
                                     : JointBhmSums::automatic;
          },
          "where update(samples, ctx) lists features and adds the sums: 'automatic' (default: "
          "the device when it is a GPU with doubles, else the host), 'host' or 'device'");
  add_fields_repr(jopt);

  py::class_<JointBhmStats>(m, "JointBhmStats", "Counters of the last JointBhm.update().")
      .def_readonly("samples", &JointBhmStats::samples)
      .def_readonly("active", &JointBhmStats::active, "kernels solved for")
      .def_readonly("cg_iterations", &JointBhmStats::cg_iterations)
      .def_readonly("residual", &JointBhmStats::residual)
      .def_readonly("sums_on_device", &JointBhmStats::sums_on_device,
                    "the features and sums ran on the context's device");
}

// The online joint BHM, under its lock.
void bind_learn_joint_bhm(py::module_& m) {
  py::class_<PyJointBhm>(
      m, "JointBhm",
      "Online Bayesian Hilbert map with the joint posterior: overlapping grid\n"
      "kernels, updated scan by scan (each posterior the next prior). Host only.")
      .def(py::init([](int dim, py::object lo, py::object hi, const py::kwargs& kw) {
             JointBhmOptions o = options_from<JointBhmOptions>(kw, "JointBhm");
             if (lo.is_none() != hi.is_none())
               throw py::value_error("give both lo and hi, or neither");
             if (lo.is_none()) return PyJointBhm(dim, o);
             double l[3], h[3];
             box_arg(lo.cast<std::vector<double>>(), hi.cast<std::vector<double>>(), dim, l, h);
             return PyJointBhm(dim, l, h, o);
           }),
           "dim"_a = 2, "lo"_a = py::none(), "hi"_a = py::none(),
           "dim: 2 or 3. lo, hi: bounds of the grid, metres (default None: unbounded, tiles\n"
           "allocated where samples arrive). Keyword arguments: JointBhmOptions fields\n"
           "(spacing=0.5 m, gamma=0 -> from neighbour_phi=0.19, prior_var=10, bias=True, ...).")
      .def("update", unlocked(&JointBhm::update), "samples"_a, "ctx"_a = nullptr,
           "Adds one scan's LabelledPoints (EM over its xi, conjugate gradients). ctx: a\n"
           "Context whose host helper thread shares the work (default None: this thread\n"
           "alone; the result is the same bit for bit).")
      .def(
          "update_by_scan",
          [](PyJointBhm& b, const LabelledPoints& samples, Context* ctx) {
            py::gil_scoped_release release;
            std::lock_guard<std::mutex> lock(*b.mu);
            b.update_by_scan(samples, ctx);
          },
          "samples"_a, "ctx"_a = nullptr,
          "One update() per scan index, in increasing order, each with ctx (see update()).")
      .def("set_time", unlocked(&JointBhm::set_time), "seconds"_a,
           "The sensor time of the data update() adds next (a scan's stamp). With\n"
           "half_life > 0 what was learned fades by 2**(-(t - time) / half_life); an\n"
           "earlier time changes nothing; the first call only sets the clock.")
      .def_property_readonly("time", &JointBhm::time, "the clock set_time() last advanced")
      .def("catch_up", unlocked(&JointBhm::catch_up),
           "Applies the fading every tile is owed now (map() does it on a copy otherwise).")
      .def(
          "seed_unreached",
          [](PyJointBhm& b, const KernelMap& field, double min_var, double min_support) {
            KernelMap copy = field;  // under the GIL: no other thread changes it meanwhile
            py::gil_scoped_release release;
            std::lock_guard<std::mutex> lock(*b.mu);
            return b.seed_unreached(copy, min_var, min_support);
          },
          "field"_a, "min_var"_a = 1.0, "min_support"_a = 0.3,
          "Seeds the prior of kernels no sample reached from another KernelMap (RePOT).\n"
          "Returns the number seeded.")
      .def("map", unlocked(&JointBhm::map), "ctx"_a = nullptr, "polish_tolerance"_a = 1e-8,
           "The KernelMap: posterior means, variances that reproduce the predictive variance\n"
           "at each centre, and the bias. With ctx its polishing solve runs on the context's\n"
           "host team (the same map). polish_tolerance: that solve's relative residual.")
      .def(
          "predict_exact",
          [](PyJointBhm& b, py::handle points) {
            Points p = points_arg(points, b.dim, "points");
            py::array_t<double> mean(static_cast<py::ssize_t>(p.n)),
                var(static_cast<py::ssize_t>(p.n));
            double *pm = mean.mutable_data(), *pv = var.mutable_data();
            {
              py::gil_scoped_release release;
              std::lock_guard<std::mutex> lock(*b.mu);
              b.predict_exact(p.data, p.n, pm, pv);
            }
            return py::make_tuple(mean, var);
          },
          "points"_a,
          "(mean, var) of the logit at points by a sparse Cholesky factorisation: small maps.")
      .def_readonly("dim", &PyJointBhm::dim)
      .def("__len__", unlocked(&JointBhm::size))
      .def_property_readonly("tiles", unlocked(&JointBhm::tiles))
      .def_property_readonly("bounded", unlocked(&JointBhm::bounded))
      .def_property_readonly("memory_bytes", unlocked(&JointBhm::memory_bytes))
      .def_property_readonly("gamma", unlocked(&JointBhm::gamma), "kernel width, 1/m^2")
      .def_property_readonly("options", unlocked(&JointBhm::options))
      .def_property_readonly("last_stats", unlocked(&JointBhm::last_stats));
}

// AbhmPrior and AbhmParams: ABHM's model.
void bind_learn_abhm_params(py::module_& m) {
  py::class_<AbhmPrior> prior(m, "AbhmPrior", "Priors of ABHM (SPEC section 3).");
  prior.def(py::init([](const py::kwargs& kw) { return options_from<AbhmPrior>(kw, "AbhmPrior"); }))
      .def_readwrite("w_sd", &AbhmPrior::w_sd, "sd of the weights' Normal prior (default 900)")
      .def_readwrite("h_sd", &AbhmPrior::h_sd, "sd of the positions' prior, metres (default 10)")
      .def_readwrite("g_shape", &AbhmPrior::g_shape, "Gamma prior of gamma: shape (default 1.05)")
      .def_readwrite("g_rate", &AbhmPrior::g_rate, "Gamma prior of gamma: rate, m^2 (default 12)");
  add_fields_repr(prior);

  py::class_<AbhmParams>(m, "AbhmParams",
                         "ABHM variational parameters (sd = softplus(s)); copies in and out.")
      .def_readonly("dim", &AbhmParams::dim)
      .def("__len__", &AbhmParams::size)
      .def_property_readonly("h_grid",
                             [](const AbhmParams& p) { return points_array(p.h_grid, p.dim); })
      .def_property_readonly("h_loc",
                             [](const AbhmParams& p) { return points_array(p.h_loc, p.dim); })
      .def_property_readonly("w_loc",
                             [](const AbhmParams& p) {
                               return to_array(p.w_loc, {static_cast<py::ssize_t>(p.size())});
                             })
      .def_property_readonly("g_loc",
                             [](const AbhmParams& p) {
                               return to_array(p.g_loc, {static_cast<py::ssize_t>(p.size())});
                             })
      .def(
          "flat",
          [](const AbhmParams& p) {
            auto v = p.flat();
            return to_array(v, {static_cast<py::ssize_t>(v.size())});
          },
          "Trainable parameters as one float64 vector (w_loc, w_s, h_loc, h_s, g_loc, g_s, b_loc, "
          "b_s).")
      .def(
          "set_flat",
          [](AbhmParams& p, py::handle v) {
            p.set_flat(doubles_arg(v, static_cast<long>(p.flat().size()), "flat"));
          },
          "v"_a)
      .def("to_map", &AbhmParams::to_map, "mean_gamma"_a = false,
           "The KernelMap of q's means (gamma the LogNormal's median; mean_gamma: its mean).");
}

// ABHM's starting kernels, parameter files and training.
void bind_learn_abhm_training(py::module_& m) {
  m.def(
      "abhm_init_grid",
      [](const std::vector<double>& lo, const std::vector<double>& hi, double spacing,
         double gamma0) {
        int dim = static_cast<int>(lo.size());
        double l[3], h[3];
        box_arg(lo, hi, dim, l, h);
        return abhm_init_grid(dim, l, h, spacing, gamma0);
      },
      "lo"_a, "hi"_a, "spacing"_a, "gamma0"_a = 1.0,
      "ABHM kernels on a grid spacing metres apart over [lo, hi]; starting width gamma0 1/m^2.");
  m.def(
      "abhm_init_halton",
      [](const std::vector<double>& lo, const std::vector<double>& hi, std::size_t count,
         double gamma0) {
        int dim = static_cast<int>(lo.size());
        double l[3], h[3];
        box_arg(lo, hi, dim, l, h);
        return abhm_init_halton(dim, l, h, count, gamma0);
      },
      "lo"_a, "hi"_a, "count"_a, "gamma0"_a = 1.0,
      "count ABHM kernels at Halton points over [lo, hi]; starting width gamma0 1/m^2.");
  m.def("write_abhm_params", &write_abhm_params, "params"_a, "path"_a);
  m.def("read_abhm_params", &read_abhm_params, "path"_a, py::call_guard<py::gil_scoped_release>());
  m.def(
      "abhm_train",
      [](AbhmParams params, const LabelledPoints& data, Context* ctx, std::size_t steps,
         std::size_t batch, double lr, std::uint64_t seed, int mc_samples, py::object prior,
         py::object progress, std::size_t report_every, const std::string& checkpoint,
         std::size_t checkpoint_every, std::size_t max_steps_this_call) {
        AbhmOptions o;
        if (!prior.is_none()) o.prior = prior.cast<AbhmPrior>();
        o.steps = steps;
        o.batch = batch;
        o.lr = lr;
        o.seed = seed;
        o.mc_samples = mc_samples;
        o.report_every = report_every;
        o.checkpoint = checkpoint;
        o.checkpoint_every = checkpoint_every;
        o.max_steps_this_call = max_steps_this_call;
        o.device = ctx;
        if (!progress.is_none()) {
          // Runs on the training thread without the GIL: take it for the Python call. An
          // exception from it stops training and reaches the caller.
          o.progress = [progress](std::size_t step, double elbo) {
            py::gil_scoped_acquire acquire;
            progress(step, elbo);
          };
        }
        std::size_t done;
        {
          py::gil_scoped_release release;
          done = abhm_train(params, data, o);
        }
        return py::make_tuple(params, done);
      },
      "params"_a, "data"_a, "ctx"_a = nullptr, "steps"_a = 2450, "batch"_a = 256, "lr"_a = 0.01,
      "seed"_a = 1, "mc_samples"_a = 1, "prior"_a = py::none(), "progress"_a = py::none(),
      "report_every"_a = 100, "checkpoint"_a = "", "checkpoint_every"_a = 500,
      "max_steps_this_call"_a = 0,
      "Trains ABHM by stochastic variational inference with Adam; returns (params, steps done).\n"
      "params: AbhmParams to start from (not changed); data: LabelledPoints; ctx: device for\n"
      "the per-sample sums (default None: the CPU reference); steps: Adam steps (default 2450,\n"
      "the SPEC's); batch: samples per step (256); lr: Adam step size (0.01); seed (1);\n"
      "mc_samples: noise draws per step (1); prior: AbhmPrior (default its defaults);\n"
      "progress: callable(step, elbo) every report_every steps (100); checkpoint: file written\n"
      "every checkpoint_every steps (500) and read to resume; max_steps_this_call: 0 no limit.");
}

}  // namespace

void bind_learn(py::module_& m) {
  bind_learn_bhm(m);
  bind_learn_joint_bhm_options(m);
  bind_learn_joint_bhm(m);
  bind_learn_abhm_params(m);
  bind_learn_abhm_training(m);
}

}  // namespace potmap::python
