// Procedural towns and the ray caster (uniform grid over obstacle bounding boxes).
#include <algorithm>
#include <cmath>
#include <limits>

#include "data/sim_rng.hpp"
#include "potmap/data/simulator.hpp"
#include "potmap/error.hpp"

namespace potmap {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

void make_ccw(std::vector<double>& p) {
  double a = 0;
  const std::size_t n = p.size() / 2;
  for (std::size_t i = 0; i < n; ++i) {
    const std::size_t j = (i + 1) % n;
    a += p[2 * i] * p[2 * j + 1] - p[2 * j] * p[2 * i + 1];
  }
  if (a < 0)
    for (std::size_t i = 0, j = n - 1; i < j; ++i, --j) {
      std::swap(p[2 * i], p[2 * j]);
      std::swap(p[2 * i + 1], p[2 * j + 1]);
    }
}

// Horizontal entry/exit distances of the 2D ray o + t d (|d| = 1) through an obstacle.
bool clip2d(const Obstacle& ob, double ox, double oy, double dx, double dy, double& tin,
            double& tout) {
  tin = -kInf;
  tout = kInf;
  if (ob.polygon.empty()) {
    const double px = ox - ob.cx, py = oy - ob.cy;
    const double b = dx * px + dy * py, c = px * px + py * py - ob.radius * ob.radius;
    const double disc = b * b - c;
    if (disc < 0) return false;
    const double r = std::sqrt(disc);
    tin = -b - r;
    tout = -b + r;
    return true;
  }
  const auto& p = ob.polygon;
  const std::size_t n = p.size() / 2;
  for (std::size_t i = 0; i < n; ++i) {
    const std::size_t j = (i + 1) % n;
    const double nx = p[2 * j + 1] - p[2 * i + 1], ny = -(p[2 * j] - p[2 * i]);
    const double num = nx * (p[2 * i] - ox) + ny * (p[2 * i + 1] - oy);
    const double den = nx * dx + ny * dy;
    if (den == 0) {
      if (num < 0) return false;
    } else if (den < 0) {
      tin = std::max(tin, num / den);
    } else {
      tout = std::min(tout, num / den);
    }
    if (tin > tout) return false;
  }
  return true;
}

// First horizontal distance t > 0 at which the 3D ray (height z + m t) is inside the obstacle.
double hit_obstacle(const Obstacle& ob, double ox, double oy, double oz, double dx, double dy,
                    double m) {
  double tin, tout;
  if (!clip2d(ob, ox, oy, dx, dy, tin, tout)) return kInf;
  if (tin <= 0) return kInf;  // the sensor is inside (a vehicle passing through it): ignore
  double ta = -kInf, tb = kInf;
  if (m == 0) {
    if (oz < ob.z0 || oz > ob.z1) return kInf;
  } else {
    ta = (ob.z0 - oz) / m;
    tb = (ob.z1 - oz) / m;
    if (ta > tb) std::swap(ta, tb);
  }
  const double lo = std::max(tin, ta), hi = std::min(tout, tb);
  return lo <= hi && lo > 0 ? lo : kInf;
}

bool inside2d(const Obstacle& ob, double x, double y) {
  if (ob.polygon.empty()) return std::hypot(x - ob.cx, y - ob.cy) <= ob.radius;
  const auto& p = ob.polygon;
  const std::size_t n = p.size() / 2;
  for (std::size_t i = 0; i < n; ++i) {
    const std::size_t j = (i + 1) % n;
    const double cr =
        (p[2 * j] - p[2 * i]) * (y - p[2 * i + 1]) - (p[2 * j + 1] - p[2 * i + 1]) * (x - p[2 * i]);
    if (cr < 0) return false;
  }
  return true;
}

void bbox(const Obstacle& ob, double& x0, double& y0, double& x1, double& y1) {
  if (ob.polygon.empty()) {
    x0 = ob.cx - ob.radius, x1 = ob.cx + ob.radius, y0 = ob.cy - ob.radius, y1 = ob.cy + ob.radius;
    return;
  }
  x0 = y0 = kInf;
  x1 = y1 = -kInf;
  for (std::size_t i = 0; i + 1 < ob.polygon.size(); i += 2) {
    x0 = std::min(x0, ob.polygon[i]), x1 = std::max(x1, ob.polygon[i]);
    y0 = std::min(y0, ob.polygon[i + 1]), y1 = std::max(y1, ob.polygon[i + 1]);
  }
}

}  // namespace

Obstacle box_obstacle(Obstacle::Kind kind, double cx, double cy, double len, double wid, double yaw,
                      double z0, double z1) {
  Obstacle o;
  o.kind = kind;
  o.z0 = z0;
  o.z1 = z1;
  const double c = std::cos(yaw), s = std::sin(yaw);
  const double hx[4] = {-len / 2, len / 2, len / 2, -len / 2};
  const double hy[4] = {-wid / 2, -wid / 2, wid / 2, wid / 2};
  for (int k = 0; k < 4; ++k) {
    o.polygon.push_back(cx + c * hx[k] - s * hy[k]);
    o.polygon.push_back(cy + s * hx[k] + c * hy[k]);
  }
  make_ccw(o.polygon);
  return o;
}

Town::Town(const std::string& name, const TownStyle& st, std::uint64_t seed)
    : name_(name), style_(st) {
  if (st.blocks_x < 1 || st.blocks_y < 1 || !(st.block > 10) || !(st.street > 4))
    throw ArgumentError("Town: need at least one block, block > 10 m, street > 4 m");
  data::SimRng rng{seed ^ 0x70776e};
  const double pitch = st.block + st.street;
  width_ = st.blocks_x * pitch + st.street;
  height_ = st.blocks_y * pitch + st.street;
  auto rect = [&](Obstacle::Kind kind, const double P[2], const double u[2], const double v[2],
                  double s0, double s1, double e0, double e1, double z1) {
    Obstacle o;
    o.kind = kind;
    o.z1 = z1;
    const double ss[4] = {s0, s1, s1, s0}, ee[4] = {e0, e0, e1, e1};
    for (int k = 0; k < 4; ++k) {
      o.polygon.push_back(P[0] + ss[k] * u[0] + ee[k] * v[0]);
      o.polygon.push_back(P[1] + ss[k] * u[1] + ee[k] * v[1]);
    }
    make_ccw(o.polygon);
    obs_.push_back(std::move(o));
  };
  for (int bi = 0; bi < st.blocks_x; ++bi)
    for (int bj = 0; bj < st.blocks_y; ++bj) {
      const double x0 = st.street + bi * pitch, y0 = st.street + bj * pitch;
      const double x1 = x0 + st.block, y1 = y0 + st.block;
      const double Ps[4][2] = {{x0, y0}, {x1, y0}, {x1, y1}, {x0, y1}};
      const double Us[4][2] = {{1, 0}, {0, 1}, {-1, 0}, {0, -1}};
      const double Vs[4][2] = {{0, 1}, {-1, 0}, {0, -1}, {1, 0}};
      const double L = st.block;
      for (int side = 0; side < 4; ++side) {
        const double *P = Ps[side], *u = Us[side], *v = Vs[side];
        // Buildings: slots along the side.
        double s = st.setback;
        while (s < L - st.setback - 4) {
          double w = st.shape == 0   ? rng.range(8, 20)
                     : st.shape == 1 ? rng.range(20, 40)
                                     : rng.range(7, 12);
          w = std::min(w, L - st.setback - s);
          if (rng.uniform() < st.building_fill) {
            const double h = st.shape == 1 ? rng.range(10, 40) : rng.range(5, 20);
            if (st.shape == 2) {
              const double e = st.setback + w / 2 + rng.range(0, 3);
              const double cx = P[0] + (s + w / 2) * u[0] + e * v[0];
              const double cy = P[1] + (s + w / 2) * u[1] + e * v[1];
              obs_.push_back(box_obstacle(Obstacle::kBuilding, cx, cy, w * 0.9, w * 0.8,
                                          std::atan2(u[1], u[0]) + rng.range(-0.4, 0.4), 0, h));
            } else {
              const double d = st.shape == 0 ? rng.range(10, 18) : rng.range(14, 24);
              rect(Obstacle::kBuilding, P, u, v, s, s + w, st.setback, st.setback + d, h);
              if (st.shape == 1 && rng.uniform() < 0.5)  // an L: a wing back into the block
                rect(Obstacle::kBuilding, P, u, v, s, s + std::min(w, 10.0), st.setback + d,
                     std::min(st.setback + d + rng.range(8, 18), L / 2), h);
            }
          }
          s += w + rng.range(1, st.shape == 1 ? 10 : 4);
        }
        // Street furniture along the curb (cars in the street, poles and trees on the sidewalk).
        auto place = [&](double rate, auto&& make) {
          const long n = std::lround(L / 100 * rate + rng.range(-0.5, 0.5));
          for (long k = 0; k < n; ++k) make(rng.range(4, L - 4));
        };
        const double yaw = std::atan2(u[1], u[0]);
        place(st.cars_per_100m, [&](double t) {
          obs_.push_back(box_obstacle(Obstacle::kCar, P[0] + t * u[0] - 1.1 * v[0],
                                      P[1] + t * u[1] - 1.1 * v[1], 4.5, 1.9, yaw, 0, 1.5));
        });
        place(st.poles_per_100m, [&](double t) {
          Obstacle o;
          o.kind = Obstacle::kPole;
          o.cx = P[0] + t * u[0] + 0.4 * v[0];
          o.cy = P[1] + t * u[1] + 0.4 * v[1];
          o.radius = 0.15;
          o.z1 = 7;
          obs_.push_back(o);
        });
        place(st.trees_per_100m, [&](double t) {
          Obstacle o;
          o.kind = Obstacle::kTree;
          o.cx = P[0] + t * u[0] + 1.0 * v[0];
          o.cy = P[1] + t * u[1] + 1.0 * v[1];
          o.radius = rng.range(0.2, 0.4);
          o.z1 = rng.range(4, 9);
          obs_.push_back(o);
        });
      }
    }
  build_grid();
}

Town Town::builtin(const std::string& name, std::uint64_t seed) {
  TownStyle s;
  if (name == "town1") {
    s.shape = 0;
  } else if (name == "town2") {
    s.blocks_x = 3, s.blocks_y = 3, s.block = 80, s.street = 16, s.shape = 1;
    s.building_fill = 0.6, s.trees_per_100m = 8, s.cars_per_100m = 3;
  } else if (name == "town3") {
    s.blocks_x = 5, s.blocks_y = 4, s.block = 45, s.street = 11, s.shape = 2;
    s.building_fill = 0.9, s.poles_per_100m = 8, s.cars_per_100m = 9, s.trees_per_100m = 1;
  } else {
    throw ArgumentError("unknown town '" + name + "' (built-in: town1, town2, town3)");
  }
  return Town(name, s, seed);
}

void Town::street_centre(int i, int j, double& x, double& y) const {
  const double pitch = style_.block + style_.street;
  x = style_.street / 2 + i * pitch;
  y = style_.street / 2 + j * pitch;
}

void Town::build_grid() {
  gx_ = static_cast<int>(std::ceil(width_ / cell_)) + 1;
  gy_ = static_cast<int>(std::ceil(height_ / cell_)) + 1;
  grid_.assign(static_cast<std::size_t>(gx_) * gy_, {});
  for (std::uint32_t k = 0; k < obs_.size(); ++k) {
    double x0, y0, x1, y1;
    bbox(obs_[k], x0, y0, x1, y1);
    const int i0 = std::clamp(static_cast<int>(std::floor(x0 / cell_)), 0, gx_ - 1);
    const int i1 = std::clamp(static_cast<int>(std::floor(x1 / cell_)), 0, gx_ - 1);
    const int j0 = std::clamp(static_cast<int>(std::floor(y0 / cell_)), 0, gy_ - 1);
    const int j1 = std::clamp(static_cast<int>(std::floor(y1 / cell_)), 0, gy_ - 1);
    for (int i = i0; i <= i1; ++i)
      for (int j = j0; j <= j1; ++j) grid_[static_cast<std::size_t>(j) * gx_ + i].push_back(k);
  }
}

bool Town::occupied(double x, double y, const std::vector<Obstacle>* extra) const {
  if (extra)
    for (const Obstacle& o : *extra)
      if (inside2d(o, x, y)) return true;
  const int i = static_cast<int>(std::floor(x / cell_)),
            j = static_cast<int>(std::floor(y / cell_));
  if (!(i >= 0 && i < gx_ && j >= 0 && j < gy_)) return false;
  for (std::uint32_t k : grid_[static_cast<std::size_t>(j) * gx_ + i])
    if (inside2d(obs_[k], x, y)) return true;
  return false;
}

bool Town::occupied(double x, double y, double z, const std::vector<Obstacle>* extra) const {
  if (z < 0) return true;
  if (extra)
    for (const Obstacle& o : *extra)
      if (z >= o.z0 && z <= o.z1 && inside2d(o, x, y)) return true;
  const int i = static_cast<int>(std::floor(x / cell_)),
            j = static_cast<int>(std::floor(y / cell_));
  if (!(i >= 0 && i < gx_ && j >= 0 && j < gy_)) return false;
  for (std::uint32_t k : grid_[static_cast<std::size_t>(j) * gx_ + i])
    if (z >= obs_[k].z0 && z <= obs_[k].z1 && inside2d(obs_[k], x, y)) return true;
  return false;
}

double Town::cast(double x, double y, double z, double yaw, double elev, double max_range,
                  bool ground, const std::vector<Obstacle>* extra) const {
  const double dx = std::cos(yaw), dy = std::sin(yaw), ce = std::cos(elev);
  const double m = std::tan(elev);
  const double tmax = max_range * ce;  // horizontal reach
  double best = kInf;
  if (ground && m < 0) best = -z / m;
  if (extra)
    for (const Obstacle& o : *extra) best = std::min(best, hit_obstacle(o, x, y, z, dx, dy, m));
  // Amanatides-Woo walk over the grid cells the horizontal ray crosses.
  int i = static_cast<int>(std::floor(x / cell_)), j = static_cast<int>(std::floor(y / cell_));
  const int si = dx > 0 ? 1 : -1, sj = dy > 0 ? 1 : -1;
  const double ddx = dx != 0 ? cell_ / std::fabs(dx) : kInf;
  const double ddy = dy != 0 ? cell_ / std::fabs(dy) : kInf;
  double tx = dx != 0 ? ((dx > 0 ? (i + 1) * cell_ : i * cell_) - x) / dx : kInf;
  double ty = dy != 0 ? ((dy > 0 ? (j + 1) * cell_ : j * cell_) - y) / dy : kInf;
  double t = 0;
  while (t <= tmax && t < best) {
    if (i >= 0 && i < gx_ && j >= 0 && j < gy_)
      for (std::uint32_t k : grid_[static_cast<std::size_t>(j) * gx_ + i])
        best = std::min(best, hit_obstacle(obs_[k], x, y, z, dx, dy, m));
    else if ((i < 0 && si < 0) || (i >= gx_ && si > 0) || (j < 0 && sj < 0) || (j >= gy_ && sj > 0))
      break;  // left the town for good
    if (tx < ty) {
      t = tx;
      tx += ddx;
      i += si;
    } else {
      t = ty;
      ty += ddy;
      j += sj;
    }
  }
  const double r = best / ce;
  return r <= max_range ? r : kInf;
}

}  // namespace potmap
