#include "potmap/map/synthetic.hpp"

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

namespace potmap {

namespace {

struct Box {
  double x0, x1, y0, y1;
};

constexpr double kWidth = 80, kHeight = 60;

std::vector<Box> obstacles(std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0, 1);
  std::vector<Box> boxes;
  // Buildings on a loose block grid, a few thin walls and small posts (sharp features).
  for (int bx = 0; bx < 4; ++bx)
    for (int by = 0; by < 3; ++by) {
      if (u(rng) < 0.2) continue;
      const double cx = 10 + bx * 20 + (u(rng) - 0.5) * 4, cy = 10 + by * 20 + (u(rng) - 0.5) * 4;
      const double w = 4 + u(rng) * 8, h = 4 + u(rng) * 8;
      boxes.push_back({cx - w / 2, cx + w / 2, cy - h / 2, cy + h / 2});
    }
  for (int i = 0; i < 6; ++i) {
    const double x = 5 + u(rng) * 70, y = 5 + u(rng) * 50, len = 4 + u(rng) * 10;
    if (u(rng) < 0.5)
      boxes.push_back({x, x + len, y, y + 0.3});
    else
      boxes.push_back({x, x + 0.3, y, y + len});
  }
  for (int i = 0; i < 10; ++i) {
    const double x = 2 + u(rng) * 76, y = 2 + u(rng) * 56;
    boxes.push_back({x - 0.25, x + 0.25, y - 0.25, y + 0.25});
  }
  return boxes;
}

// Signed distance to the nearest obstacle (negative inside).
double signed_distance(const std::vector<Box>& boxes, double x, double y) {
  double best = 1e300;
  for (const Box& b : boxes) {
    const double dx = std::max({b.x0 - x, 0.0, x - b.x1});
    const double dy = std::max({b.y0 - y, 0.0, y - b.y1});
    double d = std::hypot(dx, dy);
    if (d == 0) d = -std::min({x - b.x0, b.x1 - x, y - b.y0, b.y1 - y});
    best = std::min(best, d);
  }
  return best;
}

}  // namespace

bool synthetic_occupied(std::uint32_t seed, double x, double y) {
  return signed_distance(obstacles(seed), x, y) <= 0;
}

SyntheticTruth::SyntheticTruth(std::uint32_t seed) {
  for (const Box& b : obstacles(seed)) boxes_.insert(boxes_.end(), {b.x0, b.x1, b.y0, b.y1});
}

bool SyntheticTruth::occupied(double x, double y) const {
  for (std::size_t i = 0; i + 3 < boxes_.size(); i += 4)
    if (x >= boxes_[i] && x <= boxes_[i + 1] && y >= boxes_[i + 2] && y <= boxes_[i + 3])
      return true;
  return false;
}

SyntheticScene make_synthetic_scene(std::uint32_t seed, double spacing, std::size_t test_points) {
  const std::vector<Box> boxes = obstacles(seed);
  SyntheticScene s;
  s.bounds[0] = 0;
  s.bounds[1] = kWidth;
  s.bounds[2] = 0;
  s.bounds[3] = kHeight;
  s.map.dim = 2;
  const double gamma = 1.0 / (spacing * spacing);  // neighbours overlap at exp(-1)
  for (double y = spacing / 2; y < kHeight; y += spacing)
    for (double x = spacing / 2; x < kWidth; x += spacing) {
      const double d = signed_distance(boxes, x, y);
      // A logit that is positive inside obstacles and falls off outside them; the variance is
      // small near surfaces (observed) and large deep inside buildings (never seen).
      const double w = d <= 0 ? 2.0 : -1.5 * std::min(1.0, d / (2 * spacing));
      const double var = d < -1.0 ? 50.0 : 0.05 + 0.1 * std::min(std::abs(d), 5.0);
      const double p[2] = {x, y};
      s.map.push_back(p, gamma, w, var);
    }
  std::mt19937 rng(seed * 7919u + 17u);
  std::uniform_real_distribution<double> ux(0, kWidth), uy(0, kHeight);
  s.test.dim = 2;
  std::size_t hits = 0, free = 0;
  const std::size_t want_hits = test_points / 2, want_free = test_points - want_hits;
  while (hits < want_hits || free < want_free) {
    const double x = ux(rng), y = uy(rng);
    const double d = signed_distance(boxes, x, y);
    // Hits lie on surfaces, as LIDAR returns do; free points anywhere in the open.
    if (d <= 0 && d > -0.3 && hits < want_hits) {
      ++hits;
    } else if (d > 0 && free < want_free) {
      ++free;
    } else {
      continue;
    }
    s.test.position.push_back(x);
    s.test.position.push_back(y);
    s.test.label.push_back(d <= 0 ? 1 : 0);
    s.test.scan.push_back(0);
  }
  return s;
}

}  // namespace potmap
