// wavemap does the projection, the measurement model and the wavelet octree; this file only
// translates scans and settings. Compiled with wavemap's flags (-march=native), apart from the
// rest of potmap (wavemap_grid.hpp).
#include "potmap/experiments/wavemap_grid.hpp"

#include <wavemap/core/integrator/measurement_model/continuous_beam.h>
#include <wavemap/core/integrator/projection_model/spherical_projector.h>
#include <wavemap/core/integrator/projective/coarse_to_fine/hashed_chunked_wavelet_integrator.h>
#include <wavemap/core/map/hashed_chunked_wavelet_octree.h>
#include <wavemap/core/utils/query/map_interpolator.h>
#include <wavemap/core/utils/query/probability_conversions.h>

#include <algorithm>
#include <cmath>
#include <string>

#include "potmap/error.hpp"

namespace potmap {

namespace wm = wavemap;

namespace {

constexpr double kDegree = 3.14159265358979323846 / 180.0;

wm::SphericalProjectorConfig projector_config(const WavemapProjection& p) {
  wm::SphericalProjectorConfig c;
  c.elevation = wm::CircularProjectorConfig(float(p.elevation_min * kDegree),
                                            float(p.elevation_max * kDegree), p.elevation_cells);
  c.azimuth = wm::CircularProjectorConfig(float(p.azimuth_min * kDegree),
                                          float(p.azimuth_max * kDegree), p.azimuth_cells);
  return c;
}

void check(bool valid, const std::string& what) {
  if (!valid) throw ArgumentError("WavemapGrid: wavemap refuses the " + what + " settings");
}

// The sensor-to-world pose of a 3D scan ([R | t] row-major) as wavemap's transformation.
wm::Transformation3D pose_of(const Scan& scan) {
  wm::Rotation3D::RotationMatrix r;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) r(i, j) = float(scan.pose3d[std::size_t(4 * i + j)]);
  const wm::Point3D t(float(scan.pose3d[3]), float(scan.pose3d[7]), float(scan.pose3d[11]));
  return wm::Transformation3D(wm::Rotation3D::fromApproximateRotationMatrix(r), t);
}

wm::Point3D point_at(const double* p) {
  return wm::Point3D(float(p[0]), float(p[1]), float(p[2]));
}

// R^T v for a world-frame vector v (double precision before the cast to wavemap's floats).
wm::Point3D to_sensor(const Scan& scan, const double v[3]) {
  const auto& m = scan.pose3d;
  wm::Point3D s;
  for (int j = 0; j < 3; ++j)
    s[j] = float(m[std::size_t(j)] * v[0] + m[std::size_t(4 + j)] * v[1] +
                 m[std::size_t(8 + j)] * v[2]);
  return s;
}

}  // namespace

struct WavemapGrid::Impl {
  WavemapOptions opt;
  std::shared_ptr<wm::HashedChunkedWaveletOctree> map;
  std::unique_ptr<wm::HashedChunkedWaveletIntegrator> integrator;
  double max_range = 0;  // the integrator's, metres (0: not made yet)
  WavemapProjection projection;
  std::shared_ptr<wm::ThreadPool> pool;

  void make_integrator(double range);
};

// The integrator is made at the first scan: its maximum range is the scan's when the options
// leave it at 0, and wavemap fixes it at construction.
void WavemapGrid::Impl::make_integrator(double range) {
  const wm::SphericalProjectorConfig pc = projector_config(projection);
  check(pc.isValid(false), "projection");
  auto projector = std::make_shared<wm::SphericalProjector>(pc);
  auto range_image = std::make_shared<wm::PosedImage<>>(projector->getDimensions());
  auto offsets = std::make_shared<wm::Image<wm::Vector2D>>(projector->getDimensions());
  const double range_sigma = opt.range_sigma > 0 ? opt.range_sigma : std::max(opt.cell / 2, 0.05);
  const wm::ContinuousBeamConfig bc(float(opt.angle_sigma_deg * kDegree), float(range_sigma),
                                    float(opt.scaling_free), float(opt.scaling_occupied));
  check(bc.isValid(false), "measurement model");
  auto model = std::make_shared<wm::ContinuousBeam>(bc, projector, range_image, offsets);
  const wm::ProjectiveIntegratorConfig ic(float(opt.min_range), float(range));
  check(ic.isValid(false), "integrator (min_range < max_range, both > 0)");
  integrator = std::make_unique<wm::HashedChunkedWaveletIntegrator>(ic, projector, range_image,
                                                                    offsets, model, map, pool);
  max_range = range;
}

WavemapGrid::WavemapGrid(const WavemapOptions& o, const WavemapProjection& p) {
  if (!(o.cell > 0) || !std::isfinite(o.cell))
    throw ArgumentError("WavemapGrid: cell must be > 0 metres, got " + std::to_string(o.cell));
  if (!(o.max_range >= 0)) throw ArgumentError("WavemapGrid: max_range must be >= 0");
  impl_ = std::make_unique<Impl>();
  impl_->opt = o;
  impl_->projection = p;
  wm::HashedChunkedWaveletOctreeConfig mc;
  mc.min_cell_width = float(o.cell);
  check(mc.isValid(false), "map");
  impl_->map = std::make_shared<wm::HashedChunkedWaveletOctree>(mc);
  impl_->pool = o.threads > 0 ? std::make_shared<wm::ThreadPool>(o.threads)
                              : std::make_shared<wm::ThreadPool>();
  // Settings errors surface here rather than at the first scan.
  check(projector_config(p).isValid(false), "projection");
}

WavemapGrid::~WavemapGrid() = default;
WavemapGrid::WavemapGrid(WavemapGrid&&) noexcept = default;
WavemapGrid& WavemapGrid::operator=(WavemapGrid&&) noexcept = default;

void WavemapGrid::insert(const Scan& scan) {
  Impl& m = *impl_;
  if (scan.dim != 3) throw ArgumentError("WavemapGrid::insert: a 3D scan is needed");
  const double rmax = m.opt.max_range > 0 ? m.opt.max_range : scan.max_range;
  if (!(rmax > 0) || !std::isfinite(rmax))
    throw ArgumentError("WavemapGrid::insert: no maximum range (set WavemapOptions::max_range)");
  if (!m.integrator) m.make_integrator(rmax);
  const auto o = scan.origin();
  wm::Pointcloud<>::Data points(3, long(scan.num_beams()));
  long n = 0;
  for (std::size_t i = 0; i < scan.num_hits(); ++i) {
    const double* p = &scan.hits[3 * i];
    const double v[3] = {p[0] - o[0], p[1] - o[1], p[2] - o[2]};
    if (std::isfinite(v[0] + v[1] + v[2])) points.col(n++) = to_sensor(scan, v);
  }
  // A no-return beam ends past the maximum range: wavemap marks the cells along it free up to
  // that range and updates nothing beyond (ProjectiveIntegrator::computeUpdate).
  const double far = m.max_range * 1.01 + 2 * m.opt.cell;
  for (std::size_t i = 0; i < scan.num_no_return(); ++i) {
    const double* u = &scan.no_return[3 * i];
    const double len = std::sqrt(u[0] * u[0] + u[1] * u[1] + u[2] * u[2]);
    if (!(len > 0) || !std::isfinite(len)) continue;
    const double v[3] = {far * u[0] / len, far * u[1] / len, far * u[2] / len};
    points.col(n++) = to_sensor(scan, v);
  }
  points.conservativeResize(3, n);
  const wm::PosedPointcloud<> cloud(pose_of(scan), wm::Pointcloud<>(std::move(points)));
  m.integrator->integrate(cloud);
  m.map->threshold();
}

void WavemapGrid::finish() {
  impl_->map->prune();
}

void WavemapGrid::probability(const double* points, std::size_t n, double* prob) const {
  const wm::HashedChunkedWaveletOctree& map = *impl_->map;
  for (std::size_t i = 0; i < n; ++i) {
    const wm::Point3D q = point_at(points + 3 * i);
    prob[i] = wm::convert::logOddsToProbability(wm::interpolate::nearestNeighbor(map, q));
  }
}

void WavemapGrid::observed(const double* points, std::size_t n, std::uint8_t* observed) const {
  const wm::HashedChunkedWaveletOctree& map = *impl_->map;
  for (std::size_t i = 0; i < n; ++i) {
    const wm::Point3D q = point_at(points + 3 * i);
    observed[i] = std::abs(wm::interpolate::nearestNeighbor(map, q)) >= 1e-3f ? 1 : 0;
  }
}

std::size_t WavemapGrid::memory_bytes() const {
  return impl_->map->getMemoryUsage();
}

std::size_t WavemapGrid::cells() const {
  return impl_->map->size();
}

}  // namespace potmap
