#include "bench_report.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <set>

#include "plot_text.hpp"
#include "potmap/error.hpp"
#include "potmap/experiments/figure_panels.hpp"
#include "potmap/render/colormap.hpp"
#include "potmap/version.hpp"

namespace potmap::cli {

namespace {

std::string fixed(double v, int digits) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*f", digits, v);
  return buf;
}

// Throughput in millions (or thousands) so that the columns stay narrow.
std::string rate(double v) {
  if (v >= 1e6) return fixed(v / 1e6, 2) + " M";
  if (v >= 1e3) return fixed(v / 1e3, 2) + " k";
  return fixed(v, 1) + " ";
}

}  // namespace

void print_sweep_table(std::ostream& out, const std::vector<RoutineSweep>& sweeps) {
  for (const RoutineSweep& r : sweeps) {
    out << "\n" << r.name << ": " << r.input << "\n";
    out << "  setting                                                   median ms   spread   "
        << r.unit << "\n";
    for (std::size_t i = 0; i < r.points.size(); ++i) {
      const SweepPoint& p = r.points[i];
      std::string s = (p.is_default ? "* " : "  ") + p.setting;
      s.resize(std::max<std::size_t>(s.size(), 58), ' ');
      const double spread = (p.max_s - p.min_s) / p.median_s * 100;
      std::string ms = fixed(p.median_s * 1e3, 2), sp = fixed(spread, 1) + " %";
      ms.insert(0, ms.size() < 10 ? 10 - ms.size() : 0, ' ');
      sp.insert(0, sp.size() < 9 ? 9 - sp.size() : 0, ' ');
      out << "  " << s << ms << sp << "   " << rate(p.throughput) << (i == r.best ? "  best" : "")
          << "\n";
    }
    const SweepPoint& b = r.points[r.best];
    const SweepPoint& d = r.points[r.baseline];
    out << "  best: " << b.setting << " (" << rate(b.throughput) << r.unit << ", "
        << fixed(b.throughput / d.throughput, 2) << " x the default " << d.setting << ")\n";
  }
}

nlohmann::json sweep_json(const Context& ctx, const SweepOptions& o,
                          const std::vector<RoutineSweep>& sweeps) {
  const DeviceInfo& d = ctx.info();
  nlohmann::json j;
  j["potmap_version"] = POTMAP_VERSION_STRING;
  j["device"] = {{"name", d.name},
                 {"platform", d.platform},
                 {"platform_version", d.platform_version},
                 {"driver", d.driver_version},
                 {"compute_units", d.compute_units},
                 {"is_gpu", d.is_gpu}};
  j["tuning_before"] = to_string(ctx.tuning());
  j["tuning_source"] = ctx.tuning_source();
  j["quick"] = o.quick;
  nlohmann::json routines = nlohmann::json::array();
  for (const RoutineSweep& r : sweeps) {
    nlohmann::json jr = {
        {"name", r.name},
        {"unit", r.unit},
        {"x", r.x_label},
        {"series", r.series_label},
        {"input", r.input},
        {"start", r.start},
        {"best", r.points[r.best].setting},
        {"default", r.points[r.baseline].setting},
        {"best_over_default", r.points[r.best].throughput / r.points[r.baseline].throughput}};
    for (const SweepPoint& p : r.points)
      jr["points"].push_back({{"x", p.x},
                              {"series", p.series},
                              {"setting", p.setting},
                              {"default", p.is_default},
                              {"seconds", p.seconds},
                              {"median_s", p.median_s},
                              {"min_s", p.min_s},
                              {"max_s", p.max_s},
                              {"throughput", p.throughput}});
    routines.push_back(jr);
  }
  j["routines"] = routines;
  return j;
}

namespace {

struct Canvas {
  experiment::Picture pic;
  Canvas(std::size_t w, std::size_t h) {
    pic.width = w;
    pic.height = h;
    pic.rgb.assign(w * h * 3, 255);
  }
  void set(long x, long y, Rgb c) {
    if (x < 0 || y < 0 || x >= long(pic.width) || y >= long(pic.height)) return;
    std::uint8_t* p = &pic.rgb[(std::size_t(y) * pic.width + std::size_t(x)) * 3];
    p[0] = c.r;
    p[1] = c.g;
    p[2] = c.b;
  }
  void box(long x0, long y0, long x1, long y1, Rgb c) {
    for (long y = y0; y <= y1; ++y)
      for (long x = x0; x <= x1; ++x) set(x, y, c);
  }
  // Two pixels wide, so that a line of a light colour still shows on white.
  void line(long x0, long y0, long x1, long y1, Rgb c) {
    const long steps = std::max(std::abs(x1 - x0), std::abs(y1 - y0));
    for (long s = 0; s <= steps; ++s) {
      const double t = steps ? double(s) / steps : 0;
      const long x = std::lround(x0 + t * (x1 - x0)), y = std::lround(y0 + t * (y1 - y0));
      set(x, y, c);
      set(x, y + 1, c);
    }
  }
  void ring(long cx, long cy, double r, Rgb c) {
    for (long y = cy - long(r) - 1; y <= cy + long(r) + 1; ++y)
      for (long x = cx - long(r) - 1; x <= cx + long(r) + 1; ++x)
        if (std::abs(std::hypot(double(x - cx), double(y - cy)) - r) < 0.8) set(x, y, c);
  }
};

// 65536 as "64k", 4194304 as "4M": tick labels of powers of two stay three characters.
std::string compact(long long v) {
  if (v >= (1 << 20) && v % (1 << 20) == 0) return std::to_string(v >> 20) + "M";
  if (v >= (1 << 10) && v % (1 << 10) == 0) return std::to_string(v >> 10) + "k";
  return std::to_string(v);
}

experiment::Picture panel(const RoutineSweep& r) {
  const long w = 440, h = 300, left = 12, right = 12, top = 48, bottom = 40;
  Canvas c(w, h);
  const Rgb black{0, 0, 0}, grey{215, 215, 215}, red{220, 30, 30};
  std::set<long long> xs, series;
  double ymax = 0;
  for (const SweepPoint& p : r.points) {
    xs.insert(p.x);
    series.insert(p.series);
    ymax = std::max(ymax, p.throughput * p.median_s / p.min_s);
  }
  std::map<long long, long> xpos;
  long i = 0;
  const long nx = long(xs.size());
  for (long long x : xs)
    xpos[x] = left + 10 + (nx > 1 ? i++ * (w - left - right - 20) / (nx - 1) : 0);
  const auto ypix = [&](double v) {
    return long(std::lround(h - bottom - v / ymax * double(h - top - bottom)));
  };
  for (int q = 1; q <= 4; ++q) c.box(left, ypix(ymax * q / 4), w - right, ypix(ymax * q / 4), grey);
  c.box(left, top, left, h - bottom, black);
  c.box(left, h - bottom, w - right, h - bottom, black);
  for (const auto& [x, px] : xpos) c.box(px, h - bottom + 1, px, h - bottom + 4, black);
  draw_text(c.pic, left, 4, r.name + "  top " + rate(ymax) + r.unit, black);
  long legend_x = left;
  draw_text(c.pic, legend_x, 20, r.series_label, black);
  legend_x += text_advance(2) * long(r.series_label.size() + 1);
  for (const auto& [x, px] : xpos) {
    const std::string label = compact(x);
    draw_text(c.pic, px - text_advance(2) * long(label.size()) / 2, h - bottom + 8, label, black);
  }
  draw_text(c.pic, left, h - 16, r.x_label, black);
  long s = 0;
  const long ns = long(series.size());
  for (long long sv : series) {
    const Rgb col = colormap(Colormap::Viridis, ns > 1 ? 0.85 * s++ / double(ns - 1) : 0.4);
    if (ns > 1) {  // one line: the label alone
      draw_text(c.pic, legend_x, 20, std::to_string(sv), col);
      legend_x += text_advance(2) * long(std::to_string(sv).size() + 1);
    }
    const SweepPoint* prev = nullptr;
    for (const SweepPoint& p : r.points) {
      if (p.series != sv) continue;
      const long px = xpos[p.x], py = ypix(p.throughput);
      c.box(px, ypix(p.throughput * p.median_s / p.min_s), px,
            ypix(p.throughput * p.median_s / p.max_s), col);
      if (prev) c.line(xpos[prev->x], ypix(prev->throughput), px, py, col);
      c.box(px - 2, py - 2, px + 2, py + 2, col);
      prev = &p;
    }
  }
  const SweepPoint& b = r.points[r.best];
  c.ring(xpos[b.x], ypix(b.throughput), 6, black);
  const SweepPoint& d = r.points[r.baseline];
  const long dx = xpos[d.x], dy = ypix(d.throughput);
  for (long k = -5; k <= 5; ++k) {
    c.set(dx + k, dy - 5, red);
    c.set(dx + k, dy + 5, red);
    c.set(dx - 5, dy + k, red);
    c.set(dx + 5, dy + k, red);
  }
  return c.pic;
}

}  // namespace

void write_sweep_plot(const std::vector<RoutineSweep>& sweeps, const std::string& path) {
  std::vector<experiment::Picture> panels;
  for (const RoutineSweep& r : sweeps)
    if (!r.points.empty()) panels.push_back(panel(r));
  if (panels.empty()) throw ArgumentError("bench: nothing to plot");
  // Four panels a row (every panel has the same size), 8 white pixels between them, so that a
  // sweep of every routine stays readable on a page.
  const std::size_t per_row = std::min<std::size_t>(4, panels.size()), gap = 8;
  const std::size_t pw = panels[0].width, ph = panels[0].height;
  const std::size_t rows = (panels.size() + per_row - 1) / per_row;
  Canvas all(per_row * pw + (per_row - 1) * gap, rows * ph + (rows - 1) * gap);
  for (std::size_t i = 0; i < panels.size(); ++i) {
    const std::size_t x0 = (i % per_row) * (pw + gap), y0 = (i / per_row) * (ph + gap);
    for (std::size_t y = 0; y < ph; ++y)
      std::copy_n(&panels[i].rgb[y * pw * 3], pw * 3,
                  &all.pic.rgb[((y0 + y) * all.pic.width + x0) * 3]);
  }
  experiment::write_side_by_side({&all.pic}, path, gap);
}

}  // namespace potmap::cli
