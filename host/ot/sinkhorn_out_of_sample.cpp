// The out-of-sample barycentric map (SPEC section 4, step 4; ref. [41] of the paper).

#include <cmath>
#include <string>
#include <vector>

#include "potmap/error.hpp"
#include "potmap/ot/sinkhorn.hpp"
#include "spatial/point_grid.hpp"

namespace potmap {

Eigen::MatrixXd out_of_sample_map(const SinkhornProblem& q, const Eigen::MatrixXd& barycentric,
                                  const Eigen::MatrixXd& points) {
  const Eigen::Index n = q.source.rows(), dim = q.source.cols();
  if (barycentric.rows() != n || barycentric.cols() != dim)
    throw ArgumentError("out_of_sample_map: barycentric map must be n x dim");
  if (points.rows() > 0 && points.cols() != dim)
    throw ArgumentError("out_of_sample_map: points must have the source's dimension");
  const double c = std::cos(q.angle), s = std::sin(q.angle);
  Eigen::MatrixXd out(points.rows(), dim);
  if (points.rows() == 0) return out;
  if (n == 0) throw ArgumentError("out_of_sample_map: no source points");
  // Each point's nearest source point (the first of equally near ones, as a scan in order
  // finds) from a grid over the sources: a scan of every source for every point was most of a
  // barycentric placement's time (RePOT's) with a sector's hundreds of kernels and samples.
  std::vector<double> src(std::size_t(n * dim));
  for (Eigen::Index i = 0; i < n; ++i)
    for (Eigen::Index d = 0; d < dim; ++d) src[std::size_t(i * dim + d)] = q.source(i, d);
  const detail::PointGrid grid(src, int(dim));
  double p[3] = {0, 0, 0};
  for (Eigen::Index e = 0; e < points.rows(); ++e) {
    for (Eigen::Index d = 0; d < dim; ++d) p[d] = points(e, d);
    double d2 = 0;
    const Eigen::Index k = grid.nearest(p, d2);
    if (k < 0)
      throw ArgumentError("out_of_sample_map: point " + std::to_string(e) + " is not finite");
    // The rotation is about a centre, but a difference of two rotated points only sees R.
    const Eigen::RowVectorXd u = points.row(e) - q.source.row(k);
    out.row(e) = barycentric.row(k);
    out(e, 0) += c * u(0) - s * u(1);
    out(e, 1) += s * u(0) + c * u(1);
    if (dim == 3) out(e, 2) += u(2);
  }
  return out;
}

}  // namespace potmap
