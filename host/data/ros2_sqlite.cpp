// SQLite's C API behind RAII handles; every failure an InputError naming the bag's file.
#include "data/ros2_sqlite.hpp"

#include <sqlite3.h>

#include "potmap/error.hpp"

namespace potmap::data {

void SqliteCloser::operator()(sqlite3* db) const {
  sqlite3_close_v2(db);
}
void SqliteCloser::operator()(sqlite3_stmt* st) const {
  sqlite3_finalize(st);
}

SqliteStatement::SqliteStatement(sqlite3* db, const std::string& sql, const std::string& file)
    : file_(file) {
  sqlite3_stmt* st = nullptr;
  const int rc = sqlite3_prepare_v2(db, sql.c_str(), -1, &st, nullptr);
  st_.reset(st);
  // A file that is no database fails here, at the first read of its schema.
  if (rc != SQLITE_OK)
    throw InputError(file_ + ": not a readable rosbag2 sqlite3 file (" + sqlite3_errmsg(db) +
                     ", in: " + sql + ")");
}

void SqliteStatement::bind(int index, std::int64_t v) {
  if (sqlite3_bind_int64(st_.get(), index, v) != SQLITE_OK)
    throw InputError(file_ + ": " + sqlite3_errmsg(sqlite3_db_handle(st_.get())));
}

bool SqliteStatement::step() {
  const int rc = sqlite3_step(st_.get());
  if (rc == SQLITE_ROW) return true;
  if (rc == SQLITE_DONE) return false;
  throw InputError(file_ + ": reading the bag failed (" +
                   sqlite3_errmsg(sqlite3_db_handle(st_.get())) +
                   ", in: " + sqlite3_sql(st_.get()) + ")");
}

void SqliteStatement::reset() {
  sqlite3_reset(st_.get());
  sqlite3_clear_bindings(st_.get());
}

std::int64_t SqliteStatement::integer(int column) const {
  return sqlite3_column_int64(st_.get(), column);
}

std::string SqliteStatement::text(int column) const {
  const unsigned char* t = sqlite3_column_text(st_.get(), column);
  return t ? std::string(reinterpret_cast<const char*>(t),
                         static_cast<std::size_t>(sqlite3_column_bytes(st_.get(), column)))
           : std::string();
}

const std::uint8_t* SqliteStatement::blob(int column, std::size_t& size) const {
  const void* p = sqlite3_column_blob(st_.get(), column);
  size = static_cast<std::size_t>(sqlite3_column_bytes(st_.get(), column));
  return static_cast<const std::uint8_t*>(p);
}

SqliteFile::SqliteFile(const std::string& path, std::string shown) : shown_(std::move(shown)) {
  sqlite3* db = nullptr;
  const int rc = sqlite3_open_v2(path.c_str(), &db, SQLITE_OPEN_READONLY, nullptr);
  db_.reset(db);
  if (rc != SQLITE_OK)
    throw InputError(shown_ + ": cannot open as sqlite3 (" +
                     (db ? sqlite3_errmsg(db) : sqlite3_errstr(rc)) + ")");
}

SqliteStatement SqliteFile::prepare(const std::string& sql) const {
  return SqliteStatement(db_.get(), sql, shown_);
}

bool SqliteFile::has_table(const std::string& name) const {
  SqliteStatement st = prepare("SELECT name FROM sqlite_master WHERE type='table'");
  while (st.step())
    if (st.text(0) == name) return true;
  return false;
}

bool SqliteFile::has_column(const std::string& table, const std::string& column) const {
  SqliteStatement st = prepare("PRAGMA table_info(" + table + ")");
  while (st.step())
    if (st.text(1) == column) return true;
  return false;
}

}  // namespace potmap::data
