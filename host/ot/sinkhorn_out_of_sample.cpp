// The out-of-sample barycentric map (SPEC section 4, step 4; ref. [41] of the paper).

#include <cmath>

#include "potmap/error.hpp"
#include "potmap/ot/sinkhorn.hpp"

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
  for (Eigen::Index e = 0; e < points.rows(); ++e) {
    Eigen::Index k = 0;
    (q.source.rowwise() - points.row(e)).rowwise().squaredNorm().minCoeff(&k);
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
