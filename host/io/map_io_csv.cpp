// Kernel maps as CSV text (format: include/potmap/io/map_io.hpp).
#include <cmath>
#include <map>
#include <sstream>

#include "io/file_util.hpp"
#include "io/text_io.hpp"
#include "map/map_checks.hpp"
#include "potmap/error.hpp"
#include "potmap/io/map_io.hpp"

namespace potmap {

namespace {

using detail::MapField;

std::string lower(std::string_view s) {
  std::string r(s);
  for (char& c : r)
    if (c >= 'A' && c <= 'Z') c = static_cast<char>(c - 'A' + 'a');
  return r;
}

[[noreturn]] void fail_at(const std::string& path, std::size_t line, const std::string& what) {
  throw InputError(path + ": line " + std::to_string(line) + ": " + what);
}

// The words after a keyword comment ("# bias 0.1 2" gives {"0.1", "2"}), or false when the
// comment does not start with the keyword.
bool keyword_comment(std::string_view comment, std::string_view keyword,
                     std::vector<std::string_view>& parts) {
  std::string_view rest = detail::trim(comment.substr(1));
  const std::size_t k = keyword.size();
  if (rest.substr(0, k) != keyword || (rest.size() > k && rest[k] != ' ' && rest[k] != '\t'))
    return false;
  rest = detail::trim(rest.substr(k));
  parts.clear();
  while (!rest.empty()) {
    const std::size_t sp = rest.find_first_of(" \t");
    parts.push_back(rest.substr(0, sp));
    rest = sp == std::string_view::npos ? std::string_view() : detail::trim(rest.substr(sp));
  }
  return true;
}

double comment_number(std::string_view part, const char* name, MapField field,
                      const std::string& path, std::size_t line) {
  double v = 0;
  if (!detail::parse_double(part, v))
    fail_at(path, line, std::string(name) + " " + detail::quote_value(part) + " is not a number");
  if (const char* why = detail::map_value_problem(field, v))
    fail_at(path, line, std::string(name) + " " + detail::quote_value(part) + ": " + why);
  return v;
}

// "# bias <mean> <var>" and "# cutoff <tau>": the only comments with a meaning; other comments
// are ignored.
void parse_comment(std::string_view comment, const std::string& path, std::size_t line,
                   bool& seen_cutoff, KernelMap& map) {
  std::vector<std::string_view> parts;
  if (keyword_comment(comment, "bias", parts)) {
    if (parts.size() != 2)
      fail_at(path, line,
              "bias comment " + detail::quote_value(comment) + " must be '# bias <mean> <var>'");
    if (map.has_bias) fail_at(path, line, "second bias comment");
    map.bias_mean = comment_number(parts[0], "bias mean", MapField::bias_mean, path, line);
    map.bias_var = comment_number(parts[1], "bias variance", MapField::bias_var, path, line);
    map.has_bias = true;
  } else if (keyword_comment(comment, "cutoff", parts)) {
    if (parts.size() != 1)
      fail_at(path, line,
              "cut-off comment " + detail::quote_value(comment) + " must be '# cutoff <tau>'");
    if (seen_cutoff) fail_at(path, line, "second cut-off comment");
    map.cutoff_tau = comment_number(parts[0], "cut-off", MapField::cutoff_tau, path, line);
    seen_cutoff = true;
  }
}

}  // namespace

KernelMap read_map_csv(const std::string& path) {
  const std::string text = detail::read_whole_file(path);
  detail::LineReader lines(text);
  std::string_view line;
  std::vector<std::string_view> fields;
  KernelMap map;

  // Column indices by name; -1 if absent.
  const char* names[6] = {"x", "y", "z", "gamma", "w_mean", "w_var"};
  const MapField kinds[6] = {MapField::position, MapField::position, MapField::position,
                             MapField::gamma,    MapField::w_mean,   MapField::w_var};
  int col[6] = {-1, -1, -1, -1, -1, -1};
  std::size_t ncols = 0;
  bool have_header = false, seen_cutoff = false;
  std::size_t header_line = 0;

  while (lines.next(line)) {
    const std::size_t ln = lines.line_number();
    const std::string_view t = detail::trim(line);
    if (t.empty()) continue;
    if (t.front() == '#') {
      parse_comment(t, path, ln, seen_cutoff, map);
      continue;
    }
    detail::split_commas(line, fields);
    if (!have_header) {
      have_header = true;
      header_line = ln;
      ncols = fields.size();
      std::map<std::string, int> seen;
      for (std::size_t i = 0; i < fields.size(); ++i) {
        std::string_view f = detail::trim(fields[i]);
        if (f.size() >= 2 && f.front() == '"' && f.back() == '"') f = f.substr(1, f.size() - 2);
        const std::string name = lower(f);
        if (name.empty()) continue;
        if (seen.count(name))
          fail_at(path, ln, "column " + detail::quote_value(name) + " appears twice in the header");
        seen[name] = static_cast<int>(i);
      }
      for (int k = 0; k < 6; ++k) {
        auto it = seen.find(names[k]);
        if (it != seen.end()) col[k] = it->second;
      }
      for (int k : {0, 1, 3, 4, 5})
        if (col[k] < 0)
          fail_at(path, ln,
                  std::string("missing column '") + names[k] + "' in header " +
                      detail::quote_value(line) + " (expected x,y[,z],gamma,w_mean,w_var)");
      map.dim = col[2] >= 0 ? 3 : 2;
      continue;
    }
    if (fields.size() != ncols)
      fail_at(path, ln,
              "expected " + std::to_string(ncols) + " fields as in the header (line " +
                  std::to_string(header_line) + "), found " + std::to_string(fields.size()) +
                  " in " + detail::quote_value(line));
    double v[6] = {0, 0, 0, 0, 0, 0};
    for (int k = 0; k < 6; ++k) {
      if (col[k] < 0) continue;
      const std::string_view f = fields[static_cast<std::size_t>(col[k])];
      if (!detail::parse_double(f, v[k]))
        fail_at(path, ln,
                std::string("column '") + names[k] + "': " + detail::quote_value(f) +
                    " is not a number");
      if (const char* why = detail::map_value_problem(kinds[k], v[k]))
        fail_at(path, ln,
                std::string("column '") + names[k] + "': " + detail::quote_value(f) + ": " + why);
    }
    map.push_back(v, v[3], v[4], v[5]);
  }
  if (!have_header)
    throw InputError(path + ": no header line (expected x,y[,z],gamma,w_mean,w_var)");
  return map;
}

void write_map_csv(const KernelMap& map, const std::string& path) {
  map.validate(path);
  std::string out;
  out.reserve(map.size() * (map.dim + 3) * 24 + 64);
  if (map.has_bias) {
    out += "# bias ";
    detail::append_double(out, map.bias_mean);
    out += ' ';
    detail::append_double(out, map.bias_var);
    out += '\n';
  }
  if (std::isfinite(map.cutoff_tau)) {
    out += "# cutoff ";
    detail::append_double(out, map.cutoff_tau);
    out += '\n';
  }
  out += map.dim == 3 ? "x,y,z,gamma,w_mean,w_var\n" : "x,y,gamma,w_mean,w_var\n";
  for (std::size_t i = 0; i < map.size(); ++i) {
    for (int d = 0; d < map.dim; ++d) {
      detail::append_double(out, map.position[i * map.dim + d]);
      out += ',';
    }
    detail::append_double(out, map.gamma[i]);
    out += ',';
    detail::append_double(out, map.w_mean[i]);
    out += ',';
    detail::append_double(out, map.w_var[i]);
    out += '\n';
  }
  detail::write_file_atomically(path, out);
}

}  // namespace potmap
