// Simulated scans on disk, in formats the readers load back (documented in simulator.hpp).
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <sstream>
#include <string>

#include "io/file_util.hpp"
#include "potmap/data/simulator.hpp"
#include "potmap/error.hpp"

namespace potmap {

std::string write_simulation(const Simulation& sim, const SimOptions& o, const std::string& dir) {
  namespace fs = std::filesystem;
  fs::create_directories(dir);
  constexpr double kPi = 3.14159265358979323846;
  if (!o.three_d) {
    const std::string path = (fs::path(dir) / "scans.log").string();
    std::ostringstream f;
    f << "# potmap simulated 2D scans: CARMEN ROBOTLASER1, ranges >= max range are no-returns\n";
    char buf[64];
    for (const Scan& s : sim.scans) {
      // Beams were cast at yaw - 180 deg + k * step in order; recover ranges in that order.
      const int n = static_cast<int>(std::lround(360.0 / o.step_deg));
      std::vector<double> r(n, s.max_range);
      auto bin = [&](double dx, double dy) {
        double a = std::atan2(dy, dx) - s.pose2d[2] + kPi;
        a = std::fmod(std::fmod(a, 2 * kPi) + 2 * kPi, 2 * kPi);
        return static_cast<int>(std::lround(a / (o.step_deg * kPi / 180))) % n;
      };
      for (std::size_t i = 0; i < s.num_hits(); ++i) {
        const double dx = s.hits[2 * i] - s.pose2d[0], dy = s.hits[2 * i + 1] - s.pose2d[1];
        r[bin(dx, dy)] = std::hypot(dx, dy);
      }
      const double step = o.step_deg * kPi / 180;
      f << "ROBOTLASER1 0 " << -kPi << " " << step * (n - 1) << " " << step << " " << s.max_range
        << " 0.01 0 " << n;
      for (double v : r) {
        std::snprintf(buf, sizeof buf, " %.4f", v);
        f << buf;
      }
      std::snprintf(buf, sizeof buf, " 0 %.6f %.6f %.9f", s.pose2d[0], s.pose2d[1], s.pose2d[2]);
      f << buf << buf + 2 << " 0 0 0 0 0 " << s.timestamp << " sim " << s.timestamp << "\n";
    }
    detail::write_file_atomically(path, f.str());
    return path;
  }
  fs::create_directories(fs::path(dir) / "velodyne");
  const std::string poses = (fs::path(dir) / "poses.txt").string();
  // Every file written whole and atomically (io/file_util.hpp): a full disk fails naming the
  // file and leaves no half-written scan. poses.txt comes last: a new folder that has one holds
  // every scan (an overwritten one keeps its previous poses.txt, beside the scans renamed so far).
  detail::write_file_atomically((fs::path(dir) / "calib.txt").string(),
                                "Tr: 1 0 0 0 0 1 0 0 0 0 1 0\n");
  std::ostringstream pf;
  char name[32];
  for (std::size_t n = 0; n < sim.scans.size(); ++n) {
    const Scan& s = sim.scans[n];
    const auto& T = s.pose3d;
    for (int k = 0; k < 12; ++k) pf << (k ? " " : "") << T[k];
    pf << "\n";
    std::snprintf(name, sizeof name, "%06zu.bin", n);
    std::string bin;
    bin.reserve(s.num_hits() * 16);
    for (std::size_t i = 0; i < s.num_hits(); ++i) {
      const double w[3] = {s.hits[3 * i] - T[3], s.hits[3 * i + 1] - T[7],
                           s.hits[3 * i + 2] - T[11]};
      float v[4] = {0, 0, 0, 0};
      for (int r = 0; r < 3; ++r)  // R^T (world - t): back into the sensor frame
        v[r] = static_cast<float>(T[r] * w[0] + T[4 + r] * w[1] + T[8 + r] * w[2]);
      bin.append(reinterpret_cast<const char*>(v), sizeof v);
    }
    detail::write_file_atomically((fs::path(dir) / "velodyne" / name).string(), bin);
  }
  detail::write_file_atomically(poses, pf.str());
  return poses;
}

}  // namespace potmap
