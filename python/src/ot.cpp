// Batched Sinkhorn (include/potmap/ot/sinkhorn.hpp): problems from NumPy arrays, results with
// plans and barycentric maps.

#include <pybind11/eigen.h>
#include <pybind11/stl.h>

#include "bindings.hpp"
#include "convert.hpp"
#include "potmap/ot/sinkhorn.hpp"

namespace potmap::python {

namespace py = pybind11;
using namespace pybind11::literals;

namespace {

Eigen::MatrixXd matrix_arg(py::handle obj, int dim, const char* name) {
  Points p = points_arg(obj, dim, name);
  int d = static_cast<int>(p.array.shape(1));
  Eigen::MatrixXd out(static_cast<Eigen::Index>(p.n), d);
  for (std::size_t i = 0; i < p.n; ++i)
    for (int k = 0; k < d; ++k) out(static_cast<Eigen::Index>(i), k) = p.data[i * d + k];
  return out;
}

Eigen::VectorXd vector_arg(py::handle obj, long n, const char* name) {
  if (obj.is_none()) return {};
  std::vector<double> v = doubles_arg(obj, n, name);
  return Eigen::Map<Eigen::VectorXd>(v.data(), static_cast<Eigen::Index>(v.size()));
}

// Keyword arguments of a problem beyond its points, applied to one built with them.
SinkhornProblem make_problem(py::handle source, py::handle target, const py::kwargs& kw) {
  SinkhornProblem p;
  p.source = matrix_arg(source, 0, "source");
  p.target = matrix_arg(target, static_cast<int>(p.source.cols()), "target");
  py::object obj = py::cast(std::move(p));
  set_fields(obj, kw, "SinkhornProblem", {"source", "target"});
  return obj.cast<SinkhornProblem>();
}

std::vector<SinkhornResult> run_batch(const SinkhornBatch& b, Context& ctx, const py::kwargs& kw) {
  SinkhornOptions o = options_from<SinkhornOptions>(kw, "SinkhornOptions");
  SinkhornBatch copy = b;  // under the GIL: another thread may add() to it meanwhile
  py::gil_scoped_release release;
  return copy.run(ctx, o);
}

// SinkhornProblem, built from NumPy arrays.
void bind_ot_problem(py::module_& m) {
  py::class_<SinkhornProblem> prob(
      m, "SinkhornProblem",
      "One entropic OT problem between point sets (rows of n x dim).\n"
      "Cost C_ij = |s (c + R (x_i - c)) - s y_j|^2 (optionally / its max).");
  prob.def(py::init(&make_problem), "source"_a, "target"_a,
           "source: (n, 2|3) points; target: (m, same dim). Keyword arguments: source_weights\n"
           "(n,) and target_weights (m,) (default uniform), angle radians (0), centre (3,)\n"
           "rotation centre (0), scale (1), epsilon cost units (0.005), max_iterations (1000),\n"
           "tolerance on ||P1 - a||_1 (1e-7), normalise_cost (False), extra_points (k, dim).")
      .def_property(
          "source", [](const SinkhornProblem& p) { return Eigen::MatrixXd(p.source); },
          [](SinkhornProblem& p, py::handle v) { p.source = matrix_arg(v, 0, "source"); })
      .def_property(
          "target", [](const SinkhornProblem& p) { return Eigen::MatrixXd(p.target); },
          [](SinkhornProblem& p, py::handle v) { p.target = matrix_arg(v, 0, "target"); })
      .def_property(
          "source_weights",
          [](const SinkhornProblem& p) { return Eigen::VectorXd(p.source_weights); },
          [](SinkhornProblem& p, py::handle v) {
            p.source_weights = vector_arg(v, static_cast<long>(p.source.rows()), "source_weights");
          },
          "(n,) positive, summing to 1; empty: uniform")
      .def_property(
          "target_weights",
          [](const SinkhornProblem& p) { return Eigen::VectorXd(p.target_weights); },
          [](SinkhornProblem& p, py::handle v) {
            p.target_weights = vector_arg(v, static_cast<long>(p.target.rows()), "target_weights");
          },
          "(m,) positive, summing to 1; empty: uniform")
      .def_readwrite("angle", &SinkhornProblem::angle,
                     "rotation of the source, radians (default 0)")
      .def_readwrite("centre", &SinkhornProblem::centre,
                     "rotation centre (3,), point units (default 0)")
      .def_readwrite("scale", &SinkhornProblem::scale, "factor on both sets (> 0; default 1)")
      .def_readwrite("epsilon", &SinkhornProblem::epsilon,
                     "regularisation, cost units (default 0.005)")
      .def_readwrite("max_iterations", &SinkhornProblem::max_iterations, "default 1000")
      .def_readwrite("tolerance", &SinkhornProblem::tolerance,
                     "stop at ||P 1 - a||_1 below it (1e-7)")
      .def_readwrite("normalise_cost", &SinkhornProblem::normalise_cost,
                     "divide C by its max (False)")
      .def_property(
          "extra_points", [](const SinkhornProblem& p) { return Eigen::MatrixXd(p.extra_points); },
          [](SinkhornProblem& p, py::handle v) {
            p.extra_points = matrix_arg(v, static_cast<int>(p.source.cols()), "extra_points");
          },
          "(k, dim) points sent through the out-of-sample map");
}

// SinkhornOptions: how a batch is solved.
void bind_ot_options(py::module_& m) {
  py::class_<SinkhornOptions> opt(m, "SinkhornOptions",
                                  "How a batch is solved (defaults suit PoCL).");
  opt.def(py::init([](const py::kwargs& kw) {
       return options_from<SinkhornOptions>(kw, "SinkhornOptions");
     }))
      .def_readwrite("check_every", &SinkhornOptions::check_every, "convergence check period (1)")
      .def_readwrite("epsilon_start", &SinkhornOptions::epsilon_start,
                     "annealing start, cost units (0: none)")
      .def_readwrite("epsilon_decay", &SinkhornOptions::epsilon_decay, "annealing factor (0.7)")
      .def_readwrite("want_coupling", &SinkhornOptions::want_coupling,
                     "return the n x m plan (False)")
      .def_readwrite("want_barycentric", &SinkhornOptions::want_barycentric,
                     "return the barycentric map (False)")
      .def_readwrite("use_double", &SinkhornOptions::use_double,
                     "double precision (needs fp64; False)")
      .def_readwrite("stabilised", &SinkhornOptions::stabilised,
                     "kernel-matrix scheme (True) or log domain")
      .def_readwrite("work_group", &SinkhornOptions::work_group,
                     "work-items per problem (0: device default)");
  add_fields_repr(opt);
}

// SinkhornResult: what one problem came to.
void bind_ot_result(py::module_& m) {
  py::class_<SinkhornResult>(m, "SinkhornResult", "What one problem came to.")
      .def_readonly("cost", &SinkhornResult::cost, "<P, C> with the cost used")
      .def_readonly("iterations", &SinkhornResult::iterations)
      .def_readonly("marginal_error", &SinkhornResult::marginal_error, "||P 1 - a||_1")
      .def_readonly("converged", &SinkhornResult::converged)
      .def_readonly("f", &SinkhornResult::f, "(n,) dual potential, cost units")
      .def_readonly("g", &SinkhornResult::g, "(m,) dual potential, cost units")
      .def_readonly("coupling", &SinkhornResult::coupling, "(n, m) plan (want_coupling)")
      .def_readonly("barycentric", &SinkhornResult::barycentric,
                    "(n, dim) barycentric images (want_barycentric)")
      .def_readonly("extra_mapped", &SinkhornResult::extra_mapped,
                    "(k, dim) images of extra_points")
      .def("__repr__", [](const SinkhornResult& r) {
        return "SinkhornResult(cost=" + std::to_string(r.cost) +
               ", iterations=" + std::to_string(r.iterations) +
               ", marginal_error=" + std::to_string(r.marginal_error) +
               ", converged=" + (r.converged ? "True" : "False") + ")";
      });
}

// SinkhornBatch: problems solved in one launch.
void bind_ot_batch(py::module_& m) {
  py::class_<SinkhornBatch>(m, "SinkhornBatch",
                            "Independent OT problems solved in one device launch.")
      .def(py::init<>())
      .def(
          "add",
          [](SinkhornBatch& b, py::object problem_or_source, py::object target,
             const py::kwargs& kw) {
            if (target.is_none()) {
              if (kw.size()) throw py::type_error("add(problem) takes no keyword arguments");
              return b.add(problem_or_source.cast<SinkhornProblem>());
            }
            return b.add(make_problem(problem_or_source, target, kw));
          },
          "source"_a, "target"_a = py::none(),
          "add(problem) or add(source, target, **problem fields): returns its index.")
      .def("__len__", &SinkhornBatch::size)
      .def("problem", &SinkhornBatch::problem, "i"_a)
      .def("run", &run_batch, "ctx"_a,
           "Solves every problem on ctx's device (GIL released); results in problem order.\n"
           "Keyword arguments: SinkhornOptions fields (want_coupling, want_barycentric, ...).");
}

// sinkhorn() over lists of arrays, the CPU reference, the cost and the out-of-sample map.
void bind_ot_functions(py::module_& m) {
  m.def(
      "sinkhorn",
      [](Context& ctx, const py::list& sources, const py::list& targets, py::object options,
         const py::kwargs& kw) {
        if (sources.size() != targets.size()) {
          throw py::value_error("sources and targets: " + std::to_string(sources.size()) + " and " +
                                std::to_string(targets.size()) +
                                " arrays, expected as many of each");
        }
        SinkhornBatch b;
        for (std::size_t i = 0; i < sources.size(); ++i)
          b.add(make_problem(sources[i], targets[i], kw));
        SinkhornOptions o = options.is_none() ? SinkhornOptions{} : options.cast<SinkhornOptions>();
        py::gil_scoped_release release;
        return b.run(ctx, o);
      },
      "ctx"_a, "sources"_a, "targets"_a, "options"_a = py::none(),
      "A batch from lists of arrays: problem i is (sources[i], targets[i]); keyword arguments\n"
      "are SinkhornProblem fields shared by every problem (epsilon=0.005, ...); options a\n"
      "SinkhornOptions. Returns a list of SinkhornResult.");
  m.def(
      "sinkhorn_reference", &sinkhorn_reference, "problem"_a,
      py::call_guard<py::gil_scoped_release>(),
      "Double-precision CPU reference (log domain, dense cost); coupling and barycentric filled.");
  m.def("sinkhorn_cost", &sinkhorn_cost, "problem"_a,
        "The (n, m) cost matrix of a problem, in double.");
  m.def(
      "out_of_sample_map",
      [](const SinkhornProblem& p, py::handle barycentric, py::handle points) {
        int d = static_cast<int>(p.source.cols());
        return out_of_sample_map(p, matrix_arg(barycentric, d, "barycentric"),
                                 matrix_arg(points, d, "points"));
      },
      "problem"_a, "barycentric"_a, "points"_a,
      "SPEC step 4's map: each row h of points goes to T_k + R (h - x_k), x_k the nearest source "
      "sample.");
}

}  // namespace

void bind_ot(py::module_& m) {
  bind_ot_problem(m);
  bind_ot_options(m);
  bind_ot_result(m);
  bind_ot_batch(m);
  bind_ot_functions(m);
}

}  // namespace potmap::python
