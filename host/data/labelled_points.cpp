// Labelled points as CSV text: `t,x,y[,z],occupied` (see labelled_points.hpp).
#include "potmap/data/labelled_points.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>

#include "io/file_util.hpp"
#include "io/text_io.hpp"
#include "map/point_bounds.hpp"
#include "potmap/error.hpp"

namespace potmap {

namespace {

[[noreturn]] void fail_at(const std::string& path, std::size_t line, const std::string& what) {
  throw InputError(path + ": line " + std::to_string(line) + ": " + what);
}

}  // namespace

LabelledPoints read_labelled_csv(const std::string& path) {
  const std::string text = detail::read_whole_file(path);
  detail::LineReader lines(text);
  std::string_view line;
  std::vector<std::string_view> fields;
  LabelledPoints pts;
  enum { T, X, Y, Z, OCC, NCOL };
  const char* names[NCOL] = {"t", "x", "y", "z", "occupied"};
  int col[NCOL] = {-1, -1, -1, -1, -1};
  std::size_t ncols = 0, header_line = 0;
  bool have_header = false;
  while (lines.next(line)) {
    const std::size_t ln = lines.line_number();
    const std::string_view t = detail::trim(line);
    if (t.empty() || t.front() == '#') continue;
    detail::split_commas(line, fields);
    if (!have_header) {
      have_header = true;
      header_line = ln;
      ncols = fields.size();
      std::map<std::string, int> seen;
      for (std::size_t i = 0; i < fields.size(); ++i) {
        std::string name(detail::trim(fields[i]));
        for (char& c : name)
          if (c >= 'A' && c <= 'Z') c = static_cast<char>(c - 'A' + 'a');
        if (name.empty()) continue;
        if (seen.count(name))
          fail_at(path, ln, "column " + detail::quote_value(name) + " appears twice in the header");
        seen[name] = static_cast<int>(i);
      }
      for (int k = 0; k < NCOL; ++k) {
        auto it = seen.find(names[k]);
        if (it != seen.end()) col[k] = it->second;
      }
      for (int k : {X, Y, OCC})
        if (col[k] < 0)
          fail_at(path, ln,
                  std::string("missing column '") + names[k] + "' in header " +
                      detail::quote_value(line) + " (expected t,x,y[,z],occupied)");
      pts.dim = col[Z] >= 0 ? 3 : 2;
      continue;
    }
    if (fields.size() != ncols)
      fail_at(path, ln,
              "expected " + std::to_string(ncols) + " fields as in the header (line " +
                  std::to_string(header_line) + "), found " + std::to_string(fields.size()) +
                  " in " + detail::quote_value(line));
    for (int k = X; k <= Z; ++k) {
      if (col[k] < 0) continue;
      const std::string_view f = fields[static_cast<std::size_t>(col[k])];
      double v;
      if (!detail::parse_double(f, v))
        fail_at(path, ln,
                std::string("column '") + names[k] + "': " + detail::quote_value(f) +
                    " is not a number");
      if (!std::isfinite(v))
        fail_at(
            path, ln,
            std::string("column '") + names[k] + "': " + detail::quote_value(f) + " is not finite");
      pts.position.push_back(v);
    }
    const std::string_view occ = fields[static_cast<std::size_t>(col[OCC])];
    double o;
    if (!detail::parse_double(occ, o) || (o != 0.0 && o != 1.0))
      fail_at(path, ln, "column 'occupied': " + detail::quote_value(occ) + " is not 0 or 1");
    pts.label.push_back(o == 1.0 ? 1 : 0);
    std::int64_t scan = 0;
    if (col[T] >= 0) {
      const std::string_view f = fields[static_cast<std::size_t>(col[T])];
      if (!detail::parse_int64(f, scan))
        fail_at(path, ln, "column 't': " + detail::quote_value(f) + " is not an integer");
    }
    pts.scan.push_back(scan);
  }
  if (!have_header) throw InputError(path + ": no header line (expected t,x,y[,z],occupied)");
  return pts;
}

void write_labelled_csv(const LabelledPoints& points, const std::string& path) {
  const std::size_t n = points.size();
  const std::size_t dim = static_cast<std::size_t>(points.dim);
  if (points.dim != 2 && points.dim != 3)
    throw ArgumentError(path + ": dimension must be 2 or 3, got " + std::to_string(points.dim));
  if (points.position.size() != n * dim || (!points.scan.empty() && points.scan.size() != n))
    throw ArgumentError(path + ": sizes disagree: " + std::to_string(n) + " labels, " +
                        std::to_string(points.position.size()) + " coordinates, " +
                        std::to_string(points.scan.size()) + " scan indices");
  std::string out = dim == 3 ? "t,x,y,z,occupied\n" : "t,x,y,occupied\n";
  out.reserve(out.size() + n * (dim * 24 + 12));
  for (std::size_t i = 0; i < n; ++i) {
    if (points.label[i] > 1)
      throw ArgumentError(path + ": label " + std::to_string(points.label[i]) + " of point " +
                          std::to_string(i) + " is not 0 or 1");
    out += std::to_string(points.scan.empty() ? 0 : points.scan[i]);
    for (std::size_t d = 0; d < dim; ++d) {
      const double v = points.position[i * dim + d];
      if (!std::isfinite(v))
        throw ArgumentError(path + ": point " + std::to_string(i) + " has a non-finite coordinate");
      out += ',';
      detail::append_double(out, v);
    }
    out += points.label[i] ? ",1\n" : ",0\n";
  }
  detail::write_file_atomically(path, out);
}

void LabelledPoints::bounds(double lo[3], double hi[3]) const {
  detail::point_bounds(position, size(), dim, lo, hi);
}

}  // namespace potmap
