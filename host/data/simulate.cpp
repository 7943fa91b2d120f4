// Driving a sensor through a town.
#include <cmath>

#include "data/sim_rng.hpp"
#include "potmap/data/simulator.hpp"
#include "potmap/error.hpp"

namespace potmap {

Obstacle box_obstacle(Obstacle::Kind kind, double cx, double cy, double len, double wid, double yaw,
                      double z0, double z1);

namespace {

constexpr double kPi = 3.14159265358979323846;

// A random walk over the street grid's intersections, never turning back unless forced.
std::vector<double> random_route(const Town& town, data::SimRng& rng, double length) {
  const int nx = town.intersections_x(), ny = town.intersections_y();
  int i = rng.below(nx), j = rng.below(ny), pdi = 0, pdj = 0;
  std::vector<double> pts;
  double x, y, len = 0;
  town.street_centre(i, j, x, y);
  pts = {x, y};
  const int D[4][2] = {{1, 0}, {-1, 0}, {0, 1}, {0, -1}};
  while (len < length) {
    int options[4], n = 0;
    for (int k = 0; k < 4; ++k) {
      const int a = i + D[k][0], b = j + D[k][1];
      if (a < 0 || a >= nx || b < 0 || b >= ny) continue;
      if (D[k][0] == -pdi && D[k][1] == -pdj && (pdi || pdj)) continue;
      options[n++] = k;
    }
    const int k = n ? options[rng.below(n)] : (pdi == 0 && pdj == 0 ? 0 : -1);
    const int di = k >= 0 ? D[k][0] : -pdi, dj = k >= 0 ? D[k][1] : -pdj;
    i += di, j += dj, pdi = di, pdj = dj;
    double nxp, nyp;
    town.street_centre(i, j, nxp, nyp);
    len += std::hypot(nxp - pts[pts.size() - 2], nyp - pts.back());
    pts.push_back(nxp);
    pts.push_back(nyp);
  }
  return pts;
}

// Position and heading at arc length s along a polyline, offset sideways (right) by `lane`.
void along(const std::vector<double>& p, double s, double lane, double& x, double& y, double& yaw) {
  for (std::size_t k = 0; k + 3 < p.size(); k += 2) {
    const double dx = p[k + 2] - p[k], dy = p[k + 3] - p[k + 1], l = std::hypot(dx, dy);
    if (s <= l || k + 5 >= p.size()) {
      const double f = l > 0 ? std::min(s / l, 1.0) : 0;
      yaw = std::atan2(dy, dx);
      x = p[k] + f * dx + lane * std::sin(yaw);
      y = p[k + 1] + f * dy - lane * std::cos(yaw);
      return;
    }
    s -= l;
  }
  x = p[0], y = p[1], yaw = 0;
}

}  // namespace

Simulation simulate(const Town& town, const SimOptions& o) {
  if (!(o.max_range > 0) || !(o.step_deg > 0) || !(o.spacing >= 0) ||
      (o.three_d && (o.channels < 1 || !(o.elev_max_deg >= o.elev_min_deg))))
    throw ArgumentError("simulate: max_range, step_deg > 0; spacing >= 0; channels >= 1");
  data::SimRng rng{o.seed * 0x9e3779b97f4a7c15ULL + 1};
  const double length = o.spacing * static_cast<double>(o.scans) + 1;
  const std::vector<double> route = random_route(town, rng, length);
  std::vector<std::vector<double>> others;
  for (int v = 0; v < o.moving_vehicles; ++v) others.push_back(random_route(town, rng, length * 4));
  const int beams = static_cast<int>(std::lround(360.0 / o.step_deg));
  const int rings = o.three_d ? o.channels : 1;
  Simulation sim;
  sim.scans.reserve(o.scans);
  std::vector<Obstacle> moving;
  for (std::size_t n = 0; n < o.scans; ++n) {
    double x, y, yaw;
    along(route, o.spacing * static_cast<double>(n), 0, x, y, yaw);
    sim.route.push_back(x);
    sim.route.push_back(y);
    const double time = 0.1 * static_cast<double>(n);
    moving.clear();
    for (const auto& r : others) {
      double mx, my, myaw;
      along(r, 8.0 * time, 3.5, mx, my, myaw);  // 8 m/s in the right-hand lane
      moving.push_back(box_obstacle(Obstacle::kCar, mx, my, 4.5, 1.9, myaw, 0, 1.5));
    }
    sim.moving.push_back(moving);
    Scan sc;
    sc.dim = o.three_d ? 3 : 2;
    sc.timestamp = time;
    sc.max_range = o.max_range;
    // 2D rays run 1 m above the ground, a height every obstacle spans (cars are 1.5 m tall).
    const double z = o.three_d ? o.sensor_height : 1.0;
    if (o.three_d) {
      const double c = std::cos(yaw), s = std::sin(yaw);
      sc.pose3d = {c, -s, 0, x, s, c, 0, y, 0, 0, 1, z};
    } else {
      sc.pose2d = {x, y, yaw};
    }
    for (int ring = 0; ring < rings; ++ring) {
      const double e =
          o.three_d ? (o.elev_min_deg +
                       (rings > 1 ? (o.elev_max_deg - o.elev_min_deg) * ring / (rings - 1) : 0)) *
                          kPi / 180
                    : 0;
      const double ce = std::cos(e), se = std::sin(e);
      for (int b = 0; b < beams; ++b) {
        const double a = yaw + (b * o.step_deg - 180) * kPi / 180;
        const double r =
            town.cast(x, y, z, a, e, o.max_range, o.three_d, moving.empty() ? nullptr : &moving);
        const double ca = std::cos(a), sa = std::sin(a);
        if (std::isfinite(r)) {
          sc.hits.push_back(x + r * ce * ca);
          sc.hits.push_back(y + r * ce * sa);
          if (o.three_d) sc.hits.push_back(z + r * se);
        } else {
          sc.no_return.push_back(ce * ca);
          sc.no_return.push_back(ce * sa);
          if (o.three_d) sc.no_return.push_back(se);
        }
      }
    }
    sim.scans.push_back(std::move(sc));
  }
  return sim;
}

}  // namespace potmap
