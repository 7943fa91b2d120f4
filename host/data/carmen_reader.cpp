// CARMEN log reader: one kind of laser line per log becomes the 2D scans (see read_carmen's
// doc in scan.hpp for which kind and how poses are found).
#include <algorithm>
#include <array>
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
constexpr long kMaxBeams = 100000;
// A pose-less laser line just outside the ODOM lines' time span takes the nearest ODOM pose;
// further out the robot may have moved anywhere, so it is an error. Half a second is several
// odometry periods at CARMEN's rates (10-50 Hz).
constexpr double kMaxOdomGap = 0.5;

// Line kinds in the order of preference: a log is read from the first kind it has.
enum class Kind { kFront, kRear, kRaw, kOld, kOdom, kOther };

struct LineRef {
  const char* b;
  const char* e;
  std::size_t line;
  Kind kind;
  int id;  // RAWLASERn's / LASERn's n (0 for a bare LASER); FLASER 0, ROBOTLASER1 1
};

struct Raw {
  double start, step, max_range;  // max_range < 0: decided after the whole file is read
  std::vector<double> ranges;
  double x = 0, y = 0, theta = 0, t = 0;
  bool has_t = true;
  std::size_t line;
};

struct Odom {
  double x, y, theta, t;
  std::size_t line;
};

std::string printable(const char* b, const char* e) {
  std::string s(b, e);
  for (char& c : s)
    if (static_cast<unsigned char>(c) < 0x20 || static_cast<unsigned char>(c) >= 0x7f) c = '?';
  return s;
}

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
  double finite(std::size_t i, const char* what) const {
    const double v = num(i, what);
    if (!std::isfinite(v)) fail(std::string("non-finite ") + what, str(i));
    return v;
  }
  long count(std::size_t i, const char* what, long limit) const {
    const double v = num(i, what);
    if (!(v >= 0 && v <= limit) || v != std::floor(v)) fail(std::string("bad ") + what, tok_[i]);
    return static_cast<long>(v);
  }
  [[noreturn]] void fail(const std::string& why, const std::string& value) const {
    throw InputError(path_ + ": line " + std::to_string(line_) + ": " + why + ": '" +
                     printable(value.data(), value.data() + value.size()) + "'");
  }
  void need(std::size_t n) const {
    if (tok_.size() < n)
      fail(tok_[0] + " needs at least " + std::to_string(n) + " fields, has " +
               std::to_string(tok_.size()),
           tok_.back());
  }
  std::string where() const { return path_ + ": line " + std::to_string(line_); }

 private:
  const std::string& path_;
  std::size_t line_;
  std::vector<std::string> tok_;
};

// Ranges: NaN/Inf are dropped (counted by the caller), negative ones are an error.
std::vector<double> read_ranges(const Fields& f, std::size_t first, std::size_t n) {
  std::vector<double> r(n);
  for (std::size_t k = 0; k < n; ++k) {
    r[k] = f.num(first + k, "range");
    if (r[k] < 0) f.fail("negative range", f.str(first + k));
  }
  return r;
}

// The laser lines without a field of view (FLASER, RLASER, LASER): n beams over `fov` centred
// on the heading. 180 beams are 1 degree steps over 180 degrees (the last beam at +89), 181/361
// span -90..+90 inclusive; 360 are half-degree steps ending at +89.5.
void guess_geometry(Raw& r, long n, double fov) {
  r.start = -fov / 2;
  r.step = n > 1 ? fov / (n - 1) : 0;
  if (n % 2 == 0 && n > 0) r.step = fov / n;
  r.max_range = -1;
}

// FLASER/RLASER n r_1..r_n x y theta odom_x odom_y odom_theta [timestamp host logger_timestamp]
// (several published logs end after the odometry pose: their scans are numbered). The rear
// laser looks backwards: its beams are centred on the heading plus pi.
Raw parse_flaser(const Fields& f, double fov, bool rear, std::size_t index) {
  f.need(2);
  const long n = f.count(1, "beam count", kMaxBeams);
  f.need(2 + n + 6);
  Raw r;
  r.ranges = read_ranges(f, 2, n);
  r.x = f.finite(2 + n, "pose x");
  r.y = f.finite(3 + n, "pose y");
  r.theta = f.finite(4 + n, "pose theta");
  if (rear) r.theta = std::remainder(r.theta + kPi, 2 * kPi);
  r.t = f.size() > std::size_t(8 + n) ? f.num(8 + n, "timestamp") : double(index);
  guess_geometry(r, n, fov);
  return r;
}

// type start fov res max_range accuracy remission_mode n r_1..r_n m rem_1..rem_m: the head of
// RAWLASERn and ROBOTLASER1. Returns the index of the first field after the remissions.
std::size_t parse_laser_config(const Fields& f, Raw& r) {
  f.need(10);
  r.start = f.finite(2, "start angle");
  const double fov = f.finite(3, "field of view");
  r.max_range = f.num(5, "maximum range");
  if (!(r.max_range > 0) || !std::isfinite(r.max_range)) f.fail("bad maximum range", f.str(5));
  const long n = f.count(8, "beam count", kMaxBeams);
  f.need(10 + n);
  r.ranges = read_ranges(f, 9, n);
  const long m = f.count(9 + n, "remission count", kMaxBeams);
  f.need(10 + n + m);
  r.step = n > 1 ? fov / (n - 1) : 0;
  return 10 + n + m;
}

// ROBOTLASER1 <config> laser_x laser_y laser_theta robot_x robot_y robot_theta, then CARMEN's
// tv rv forward_safety_dist side_safety_dist turn_axis timestamp host logger_timestamp. Logs
// converted by other tools end after the poses, after the velocities, or write only timestamp,
// host and logger timestamp: 0, 5 or 3 trailing fields, each unambiguous.
Raw parse_robotlaser(const Fields& f, std::size_t index) {
  Raw r;
  const std::size_t b = parse_laser_config(f, r);
  f.need(b + 6);
  r.x = f.finite(b, "laser pose x");
  r.y = f.finite(b + 1, "laser pose y");
  r.theta = f.finite(b + 2, "laser pose theta");
  const std::size_t tail = f.size() - (b + 6);
  if (tail >= 8)
    r.t = f.num(b + 11, "timestamp");
  else if (tail == 3)
    r.t = f.num(b + 6, "timestamp");
  else if (tail == 0 || tail == 5)
    r.t = double(index);
  else
    f.fail("ROBOTLASER1 has " + std::to_string(tail) +
               " fields after the robot pose (read: 0, 3, 5 or at least 8)",
           f.str(f.size() - 1));
  return r;
}

// RAWLASERn <config> timestamp host logger_timestamp: the pose comes from the ODOM lines.
Raw parse_rawlaser(const Fields& f) {
  Raw r;
  const std::size_t b = parse_laser_config(f, r);
  f.need(b + 1);
  r.t = f.finite(b, "timestamp");
  return r;
}

// LASER/LASERn n r_1..r_n [timestamp host logger_timestamp]: CARMEN's laser message before
// RAWLASER, with FLASER's geometry; the pose is the latest ODOM line before it.
Raw parse_old_laser(const Fields& f, double fov) {
  f.need(2);
  const long n = f.count(1, "beam count", kMaxBeams);
  f.need(2 + n);
  Raw r;
  r.ranges = read_ranges(f, 2, n);
  r.has_t = f.size() > std::size_t(2 + n);
  if (r.has_t) r.t = f.finite(2 + n, "timestamp");
  guess_geometry(r, n, fov);
  return r;
}

// ODOM x y theta tv rv accel timestamp host logger_timestamp; the old LASER pairing needs only
// the pose.
Odom parse_odom(const Fields& f, bool timed) {
  f.need(timed ? 8 : 4);
  Odom o;
  o.x = f.finite(1, "odometry x");
  o.y = f.finite(2, "odometry y");
  o.theta = f.finite(3, "odometry theta");
  o.t = timed ? f.finite(7, "odometry timestamp") : 0;
  return o;
}

const char* kind_name(Kind k, int id) {
  static const char* raw[] = {"RAWLASER1", "RAWLASER2", "RAWLASER3", "RAWLASER4"};
  static const char* old[] = {"LASER", "LASER1", "LASER2", "LASER3", "LASER4"};
  switch (k) {
    case Kind::kRaw:
      return raw[id - 1];
    case Kind::kOld:
      return old[id];
    case Kind::kRear:
      return "RLASER";
    default:
      return id ? "ROBOTLASER1" : "FLASER";
  }
}

// Odometry pose at time t: linear between the ODOM lines around it, the heading the shorter
// way round; the nearest one within kMaxOdomGap outside their span.
void pose_at(const std::vector<Odom>& od, Raw& r, const std::string& path, const char* name) {
  const std::string where =
      path + ": line " + std::to_string(r.line) + ": " + name + " at time " + std::to_string(r.t);
  if (od.empty()) throw InputError(where + " has no pose: the log has no ODOM line");
  auto hi =
      std::lower_bound(od.begin(), od.end(), r.t, [](const Odom& o, double t) { return o.t < t; });
  const Odom* a = nullptr;
  const Odom* b = nullptr;
  if (hi == od.end()) {
    a = b = &od.back();
  } else if (hi == od.begin() || hi->t == r.t) {
    a = b = &*hi;
  } else {
    a = &*(hi - 1);
    b = &*hi;
  }
  if (a == b && std::fabs(a->t - r.t) > kMaxOdomGap)
    throw InputError(where + " is " + std::to_string(std::fabs(a->t - r.t)) +
                     " s from the nearest ODOM line (line " + std::to_string(a->line) + ", time " +
                     std::to_string(a->t) + "); at most " + std::to_string(kMaxOdomGap) +
                     " s outside the ODOM lines' time span");
  const double w = a == b ? 0 : (r.t - a->t) / (b->t - a->t);
  r.x = a->x + w * (b->x - a->x);
  r.y = a->y + w * (b->y - a->y);
  r.theta = std::remainder(a->theta + w * std::remainder(b->theta - a->theta, 2 * kPi), 2 * kPi);
}

struct Scanned {
  std::vector<LineRef> refs;  // laser and ODOM lines, pointing into the file's bytes
  std::size_t lines = 0, other = 0;
  std::string first_other;  // the first line that is neither, for the error below
};

Kind classify(const std::string& w, int& id) {
  id = 0;
  if (w == "FLASER") return Kind::kFront;
  if (w == "ROBOTLASER1") return id = 1, Kind::kFront;
  if (w == "RLASER") return Kind::kRear;
  if (w == "ODOM") return Kind::kOdom;
  if (w.size() == 9 && w.compare(0, 8, "RAWLASER") == 0 && w[8] >= '1' && w[8] <= '4')
    return id = w[8] - '0', Kind::kRaw;
  if (w == "LASER") return Kind::kOld;
  if (w.size() == 6 && w.compare(0, 5, "LASER") == 0 && w[5] >= '1' && w[5] <= '4')
    return id = w[5] - '0', Kind::kOld;
  return Kind::kOther;
}

Scanned scan_lines(const std::string& bytes) {
  Scanned sc;
  const char* p = bytes.data();
  const char* end = p + bytes.size();
  while (p < end) {
    const char* nl = static_cast<const char*>(memchr(p, '\n', end - p));
    const char* le = nl ? nl : end;
    ++sc.lines;
    const char* s = p;
    p = nl ? nl + 1 : end;
    while (s < le && (*s == ' ' || *s == '\t')) ++s;
    if (s == le || *s == '#' || *s == '\r') continue;
    const char* w = s;
    while (w < le && *w != ' ' && *w != '\t' && *w != '\r') ++w;
    int id = 0;
    const Kind k = classify(std::string(s, w), id);
    if (k == Kind::kOther) {
      if (sc.first_other.empty()) sc.first_other = printable(s, s + std::min<long>(le - s, 40));
      ++sc.other;
      continue;
    }
    sc.refs.push_back({s, le, sc.lines, k, id});
  }
  return sc;
}

[[noreturn]] void no_laser(const std::string& path, const Scanned& sc, const std::string& hint) {
  throw InputError(path + ": no laser line among its " + std::to_string(sc.lines) + " lines" +
                   (sc.first_other.empty() ? std::string(" (the file is empty)")
                                           : " (the first reads '" + sc.first_other + "')") +
                   ": potmap reads a CARMEN log's FLASER, RLASER or ROBOTLASER1 lines, RAWLASER1-4 "
                   "lines with ODOM poses, or LASER, LASER1-4 lines with ODOM poses" +
                   hint);
}

// The kind of laser line a log is read from: the front laser with its pose (FLASER,
// ROBOTLASER1), else the rear one, else the lowest-numbered RAWLASER, else the old LASER lines.
std::pair<Kind, int> chosen_kind(const std::vector<LineRef>& refs) {
  std::pair<Kind, int> best{Kind::kOdom, 0};
  for (const LineRef& r : refs) {
    if (r.kind == Kind::kOdom) continue;
    const std::pair<Kind, int> k{r.kind, r.kind == Kind::kFront ? 0 : r.id};
    if (k < best) best = k;
  }
  return best;
}

std::vector<Raw> parse_chosen(const std::string& path, const Scanned& sc, double fov) {
  const auto [kind, id] = chosen_kind(sc.refs);
  std::vector<Raw> raws;
  std::vector<Odom> odom;
  bool have_odom = false;
  Odom latest{};
  for (const LineRef& ref : sc.refs) {
    const bool mine = ref.kind == kind && (kind == Kind::kFront || ref.id == id);
    const bool odom_line = ref.kind == Kind::kOdom && (kind == Kind::kRaw || kind == Kind::kOld);
    if (!mine && !odom_line) continue;
    Fields f(path, ref.line, ref.b, ref.e);
    if (odom_line) {
      latest = parse_odom(f, kind == Kind::kRaw);
      latest.line = ref.line;
      have_odom = true;
      if (kind == Kind::kRaw) odom.push_back(latest);
      continue;
    }
    Raw r;
    if (kind == Kind::kFront)
      r = ref.id ? parse_robotlaser(f, raws.size()) : parse_flaser(f, fov, false, raws.size());
    else if (kind == Kind::kRear)
      r = parse_flaser(f, fov, true, raws.size());
    else if (kind == Kind::kRaw)
      r = parse_rawlaser(f);
    else {
      r = parse_old_laser(f, fov);
      if (!have_odom)
        f.fail(std::string(kind_name(kind, id)) + " has no ODOM line before it", f.str(0));
      r.x = latest.x, r.y = latest.y, r.theta = latest.theta;
      if (!r.has_t) r.t = double(raws.size());
    }
    r.line = ref.line;
    raws.push_back(std::move(r));
  }
  if (kind == Kind::kRaw) {
    std::stable_sort(odom.begin(), odom.end(),
                     [](const Odom& a, const Odom& b) { return a.t < b.t; });
    for (Raw& r : raws) pose_at(odom, r, path, kind_name(kind, id));
  }
  return raws;
}

}  // namespace

// A log whose stamps do not advance from most scans to the next carries no time: a logger that
// printed them with six significant digits (CSAIL's: 1.13486e+09, 405 of 406 scans on one
// stamp, then a jump of 10,000 s). Its scans are timed by their index instead, as a log
// without stamps, so that what runs on the scans' time (forgetting) sees a clock.
void stamps_or_indices(Dataset& d) {
  const std::size_t n = d.scans.size();
  std::size_t advancing = 0;
  for (std::size_t i = 1; i < n; ++i) advancing += d.scans[i].timestamp > d.scans[i - 1].timestamp;
  if (n < 3 || 2 * advancing >= n - 1) return;
  for (std::size_t i = 0; i < n; ++i) d.scans[i].timestamp = double(i);
  d.stats.stamps_replaced = n;
}

Dataset read_carmen_log(const std::string& path, double flaser_max_range, double flaser_fov,
                        const std::string& hint) {
  if (!(flaser_fov > 0 && flaser_fov <= 2 * kPi))
    throw ArgumentError("read_carmen: flaser_fov must be in (0, 2 pi] radians");
  const std::string bytes = data::read_file_bytes(path);  // the lines point into it
  const Scanned lines = scan_lines(bytes);
  if (chosen_kind(lines.refs).first == Kind::kOdom) no_laser(path, lines, hint);
  const std::vector<Raw> raws = parse_chosen(path, lines, flaser_fov);
  Dataset out;
  out.stats.lines_skipped = lines.other + lines.refs.size() - raws.size();
  double largest = 0;
  for (const Raw& r : raws)
    for (double v : r.ranges)
      if (std::isfinite(v)) largest = std::max(largest, v);
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
  stamps_or_indices(out);
  return out;
}

Dataset read_carmen(const std::string& path, double flaser_max_range, double flaser_fov) {
  return read_carmen_log(path, flaser_max_range, flaser_fov, "");
}

}  // namespace potmap
