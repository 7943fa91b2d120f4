// CARMEN log reader: FLASER and ROBOTLASER1 lines become 2D scans.
#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include "data/file_bytes.hpp"
#include "potmap/data/scan.hpp"
#include "potmap/error.hpp"

namespace potmap {

namespace {

constexpr double kPi = 3.14159265358979323846;

struct Raw {
  double start, step, max_range;  // max_range < 0: FLASER, decided after the whole file is read
  std::vector<double> ranges;
  double x, y, theta, t;
  std::size_t line;
};

class Fields {
 public:
  Fields(const std::string& path, std::size_t line, const char* b, const char* e)
      : path_(path), line_(line) {
    const char* p = b;
    while (p < e) {
      while (p < e && (*p == ' ' || *p == '\t' || *p == '\r')) ++p;
      const char* s = p;
      while (p < e && !(*p == ' ' || *p == '\t' || *p == '\r')) ++p;
      if (p > s) tok_.emplace_back(s, p);
    }
  }
  std::size_t size() const { return tok_.size(); }
  const std::string& str(std::size_t i) const { return tok_[i]; }
  double num(std::size_t i, const char* what) const {
    if (i >= tok_.size()) fail(std::string("missing ") + what, "(end of line)");
    const std::string& s = tok_[i];
    char* end = nullptr;
    errno = 0;
    const double v = std::strtod(s.c_str(), &end);
    if (end == s.c_str() || *end != '\0') fail(std::string("non-numeric ") + what, s);
    return v;
  }
  long count(std::size_t i, const char* what, long limit) const {
    const double v = num(i, what);
    if (!(v >= 0 && v <= limit) || v != std::floor(v)) fail(std::string("bad ") + what, tok_[i]);
    return static_cast<long>(v);
  }
  [[noreturn]] void fail(const std::string& why, const std::string& value) const {
    throw InputError(path_ + ": line " + std::to_string(line_) + ": " + why + ": '" + value + "'");
  }
  void need(std::size_t n, const char* kind) const {
    if (tok_.size() < n)
      fail(std::string(kind) + " needs at least " + std::to_string(n) + " fields, has " +
               std::to_string(tok_.size()),
           tok_.empty() ? "" : tok_.back());
  }

 private:
  const std::string& path_;
  std::size_t line_;
  std::vector<std::string> tok_;
};

double finite_pose(const Fields& f, std::size_t i, const char* what) {
  const double v = f.num(i, what);
  if (!std::isfinite(v)) f.fail(std::string("non-finite ") + what, f.str(i));
  return v;
}

// Ranges: NaN/Inf are dropped (counted by the caller), negative ones are an error.
std::vector<double> read_ranges(const Fields& f, std::size_t first, std::size_t n) {
  std::vector<double> r(n);
  for (std::size_t k = 0; k < n; ++k) {
    r[k] = f.num(first + k, "range");
    if (r[k] < 0) f.fail("negative range", f.str(first + k));
  }
  return r;
}

}  // namespace

Dataset read_carmen(const std::string& path, double flaser_max_range, double flaser_fov) {
  if (!(flaser_fov > 0 && flaser_fov <= 2 * kPi))
    throw ArgumentError("read_carmen: flaser_fov must be in (0, 2 pi] radians");
  const std::string bytes = data::read_file_bytes(path);
  Dataset out;
  std::vector<Raw> raws;
  double largest = 0;
  std::size_t line = 0;
  std::string first_other;  // the first line that is not a laser line, for the error below
  const char* p = bytes.data();
  const char* end = p + bytes.size();
  constexpr long kMaxBeams = 100000;
  while (p < end) {
    const char* nl = static_cast<const char*>(memchr(p, '\n', end - p));
    const char* le = nl ? nl : end;
    ++line;
    const char* s = p;
    p = nl ? nl + 1 : end;
    while (s < le && (*s == ' ' || *s == '\t')) ++s;
    if (s == le || *s == '#' || *s == '\r') continue;
    const bool flaser = le - s >= 7 && std::string(s, 7) == "FLASER ";
    const bool robot = le - s >= 12 && std::string(s, 12) == "ROBOTLASER1 ";
    if (!flaser && !robot) {
      if (first_other.empty()) first_other = std::string(s, std::min<std::size_t>(le - s, 40));
      ++out.stats.lines_skipped;
      continue;
    }
    Fields f(path, line, s, le);
    Raw r;
    r.line = line;
    if (flaser) {
      f.need(2, "FLASER");
      const long n = f.count(1, "beam count", kMaxBeams);
      // FLASER n r_1..r_n x y theta odom_x odom_y odom_theta [timestamp host logger_timestamp]
      // (several published logs end after the odometry pose: their scans are numbered).
      f.need(2 + n + 6, "FLASER");
      r.ranges = read_ranges(f, 2, n);
      r.x = finite_pose(f, 2 + n, "pose x");
      r.y = finite_pose(f, 3 + n, "pose y");
      r.theta = finite_pose(f, 4 + n, "pose theta");
      r.t = f.size() > std::size_t(8 + n) ? f.num(8 + n, "timestamp") : double(raws.size());
      r.start = -flaser_fov / 2;
      r.step = n > 1 ? flaser_fov / (n - 1) : 0;
      // 180 beams are 1 degree steps over 180 degrees (the last beam at +89), 181/361 span
      // -90..+90 inclusive; 360 are half-degree steps ending at +89.5.
      if (n % 2 == 0 && n > 0) r.step = flaser_fov / n;
      r.max_range = -1;
    } else {
      // ROBOTLASER1 type start fov res max_range accuracy remission_mode n r.. m rem.. laser_x
      // laser_y laser_theta robot_x robot_y robot_theta tv rv fsd ssd turn_axis timestamp host lt
      f.need(10, "ROBOTLASER1");
      r.start = finite_pose(f, 2, "start angle");
      const double fov = finite_pose(f, 3, "field of view");
      r.max_range = f.num(5, "maximum range");
      if (!(r.max_range > 0) || !std::isfinite(r.max_range)) f.fail("bad maximum range", f.str(5));
      const long n = f.count(8, "beam count", kMaxBeams);
      f.need(10 + n, "ROBOTLASER1");
      r.ranges = read_ranges(f, 9, n);
      const long m = f.count(9 + n, "remission count", kMaxBeams);
      const std::size_t b = 10 + n + m;
      f.need(b + 12, "ROBOTLASER1");
      r.x = finite_pose(f, b, "laser pose x");
      r.y = finite_pose(f, b + 1, "laser pose y");
      r.theta = finite_pose(f, b + 2, "laser pose theta");
      r.t = f.num(b + 11, "timestamp");
      r.step = n > 1 ? fov / (n - 1) : 0;
    }
    for (double v : r.ranges)
      if (std::isfinite(v)) largest = std::max(largest, v);
    raws.push_back(std::move(r));
  }
  if (raws.empty())
    throw InputError(path + ": no FLASER or ROBOTLASER1 line among its " + std::to_string(line) +
                     " lines" +
                     (first_other.empty() ? std::string(" (the file is empty)")
                                          : " (the first reads '" + first_other + "')") +
                     ": potmap reads a CARMEN log's FLASER and ROBOTLASER1 laser lines");
  // FLASER carries no maximum range; readings at the device's limit are the largest in the log.
  const double auto_max = flaser_max_range > 0 ? flaser_max_range : largest * 0.999;
  out.scans.reserve(raws.size());
  for (const Raw& r : raws) {
    Scan sc;
    sc.dim = 2;
    sc.timestamp = r.t;
    sc.max_range = r.max_range > 0 ? r.max_range : auto_max;
    sc.pose2d = {r.x, r.y, r.theta};
    sc.hits.reserve(2 * r.ranges.size());
    for (std::size_t k = 0; k < r.ranges.size(); ++k) {
      const double v = r.ranges[k];
      if (!std::isfinite(v)) {
        ++out.stats.points_dropped;
        continue;
      }
      const double a = r.theta + r.start + r.step * static_cast<double>(k);
      const double c = std::cos(a), s = std::sin(a);
      if (v >= sc.max_range) {
        sc.no_return.push_back(c);
        sc.no_return.push_back(s);
      } else {
        sc.hits.push_back(r.x + v * c);
        sc.hits.push_back(r.y + v * s);
      }
    }
    out.scans.push_back(std::move(sc));
  }
  return out;
}

}  // namespace potmap
