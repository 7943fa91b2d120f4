#pragma once
// A rosbag2 .db3 file opened read-only through SQLite, with RAII handles and InputErrors that
// name the file: what the ROS 2 bag reader needs of SQLite and nothing more.
#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>

struct sqlite3;
struct sqlite3_stmt;

namespace potmap::data {

struct SqliteCloser {
  void operator()(sqlite3* db) const;
  void operator()(sqlite3_stmt* st) const;
};

class SqliteStatement {
 public:
  SqliteStatement(sqlite3* db, const std::string& sql, const std::string& file);
  /// Binds `v` to the statement's parameter `index` (1-based).
  void bind(int index, std::int64_t v);
  /// Steps to the next row: false at the end. A corrupt file throws InputError.
  bool step();
  void reset();
  std::int64_t integer(int column) const;
  std::string text(int column) const;
  /// A BLOB column, valid until the next step or reset.
  const std::uint8_t* blob(int column, std::size_t& size) const;

 private:
  std::unique_ptr<sqlite3_stmt, SqliteCloser> st_;
  std::string file_;
};

class SqliteFile {
 public:
  /// Opens `path` read-only. `shown` names the file in errors (the .db3.zstd a temporary copy
  /// was decompressed from). Throws InputError when it is no SQLite database.
  SqliteFile(const std::string& path, std::string shown);
  SqliteStatement prepare(const std::string& sql) const;
  bool has_table(const std::string& name) const;
  /// Whether `table` has a column `column`.
  bool has_column(const std::string& table, const std::string& column) const;
  const std::string& name() const { return shown_; }

 private:
  std::unique_ptr<sqlite3, SqliteCloser> db_;
  std::string shown_;
};

}  // namespace potmap::data
