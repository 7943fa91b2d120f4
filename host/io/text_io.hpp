#pragma once
// Helpers shared by the CSV readers and writers: line iteration with line numbers, field
// splitting, strict locale-independent number parsing and exact number formatting.

#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

namespace potmap::detail {

/// Shortest decimal text that reads back as exactly `v` (std::to_chars), e.g. "0.1", "1e-300".
std::string format_double(double v);
/// Appends format_double(v) to `out` without a temporary string.
void append_double(std::string& out, double v);

/// `s` without leading and trailing spaces, tabs and carriage returns.
std::string_view trim(std::string_view s);

/// Parses the whole of `s` (surrounding blanks allowed) as a double; false if anything is left
/// over, if it is empty or out of double's range. "nan" and "inf" parse (callers reject them).
bool parse_double(std::string_view s, double& v);
/// Parses the whole of `s` as a signed 64-bit integer; "12.0" style integral doubles also pass.
bool parse_int64(std::string_view s, std::int64_t& v);

/// Iterates the lines of a text held in memory. Line numbers start at 1.
class LineReader {
 public:
  explicit LineReader(const std::string& text) : text_(text) {}
  /// Next line without its terminator ("\n" or "\r\n"); false at the end.
  bool next(std::string_view& line);
  std::size_t line_number() const { return line_; }

 private:
  const std::string& text_;
  std::size_t pos_ = 0;
  std::size_t line_ = 0;
};

/// Splits a line at commas (no quoting: the formats read here never need it).
void split_commas(std::string_view line, std::vector<std::string_view>& fields);

/// "'text'" for error messages, cut to 40 characters and with control bytes escaped, so that a
/// binary file fed to a text reader gives a readable message.
std::string quote_value(std::string_view s);

}  // namespace potmap::detail
