// ROS 2 bags in rosbag2's sqlite3 storage: every .db3 file of the bag opened through SQLite, the
// messages of the chosen topics merged across files in the order of their receive times and
// decoded from CDR (ros2_messages.cpp).
#include <algorithm>
#include <cstdio>
#include <limits>
#include <map>
#include <memory>
#include <unordered_map>

#include "data/bag_source.hpp"
#include "data/ros2_bag_layout.hpp"
#include "data/ros2_messages.hpp"
#include "data/ros2_sqlite.hpp"
#include "data/ros2_zstd.hpp"
#include "potmap/error.hpp"

namespace potmap::data {

namespace {

// A message's key: its file's index above its row id (rowids stay far below 2^48).
constexpr int kFileShift = 48;
constexpr std::uint64_t kIdMask = (std::uint64_t{1} << kFileShift) - 1;

struct Topic {
  std::string name, type, serialization;
  Ros2Type kind = Ros2Type::other;
  std::size_t count = 0;
  std::string frame_id;
};

struct BagFile {
  std::unique_ptr<TempFile> copy;  // the decompressed .db3 of a .db3.zstd
  std::unique_ptr<SqliteFile> db;
  std::unordered_map<std::int64_t, std::size_t> topic_of_id;  // topics.id -> Ros2Bag::topics_
};

// A receive time in seconds, digit for digit from its nanoseconds (a double would blur the last
// digits of a time since 1970).
std::string seconds(std::int64_t ns) {
  const bool negative = ns < 0;
  const std::uint64_t a =
      negative ? 0 - static_cast<std::uint64_t>(ns) : static_cast<std::uint64_t>(ns);
  char s[48];
  std::snprintf(s, sizeof s, "%s%llu.%09llu", negative ? "-" : "",
                static_cast<unsigned long long>(a / 1000000000),
                static_cast<unsigned long long>(a % 1000000000));
  return s;
}

// One file's messages of the wanted topics in time order: a cursor of the merge across files.
struct Cursor {
  std::size_t file;
  SqliteStatement st;
  bool live;
};

class Ros2Bag final : public BagSource {
 public:
  explicit Ros2Bag(const std::string& path);
  const BagInfo& info() const override { return info_; }
  void read(const std::vector<std::string>& topics, const BagHandlers& handlers) override;
  CloudMsg read_cloud(const std::string& topic, std::uint64_t key) override;

 private:
  void open_file(const std::string& path);
  void count_messages();
  void find_frames();
  std::string where(std::size_t file, const Topic& topic, std::int64_t ns) const;
  // The message's CDR bytes: the blob itself, or its decompressed copy in `scratch`.
  const std::uint8_t* body(const SqliteStatement& st, int column, const std::string& where,
                           std::vector<std::uint8_t>& scratch, std::size_t& size) const;
  void check_cdr(const Topic& t, std::size_t file) const;

  Ros2Compression compression_ = Ros2Compression::none;
  std::vector<BagFile> files_;
  std::vector<Topic> topics_;
  std::map<std::string, std::size_t> topic_index_;
  BagInfo info_;
};

Ros2Bag::Ros2Bag(const std::string& path) {
  const Ros2BagLayout layout = find_ros2_bag(path);
  compression_ = layout.compression;
  for (const std::string& f : layout.files) open_file(f);
  count_messages();
  find_frames();
  info_.format = "ROS 2 bag (sqlite3)";
  info_.compression = compression_name(compression_);
  for (const auto& [name, i] : topic_index_) {
    const Topic& t = topics_[i];
    info_.topics.push_back({t.name, ros1_type_name(t.type), t.count, t.frame_id});
  }
}

void Ros2Bag::open_file(const std::string& path) {
  if (files_.size() > (std::numeric_limits<std::uint64_t>::max() >> kFileShift))
    throw InputError(path + ": too many files in one bag");
  BagFile f;
  std::string db_path = path;
  if (compression_ == Ros2Compression::zstd_file) {
    f.copy = std::make_unique<TempFile>("ros2-bag");
    zstd_decompress_file(path, f.copy->path());
    db_path = f.copy->path();
  }
  f.db = std::make_unique<SqliteFile>(db_path, path);
  for (const char* table : {"topics", "messages"})
    if (!f.db->has_table(table))
      throw InputError(path + ": not a rosbag2 sqlite3 file (no table '" + table + "')");
  SqliteStatement st = f.db->prepare("SELECT id, name, type, serialization_format FROM topics");
  while (st.step()) {
    const std::string name = st.text(1);
    auto [it, added] = topic_index_.emplace(name, topics_.size());
    if (added) {
      Topic t;
      t.name = name;
      t.type = st.text(2);
      t.serialization = st.text(3);
      t.kind = ros2_type(t.type);
      topics_.push_back(std::move(t));
    }
    f.topic_of_id[st.integer(0)] = it->second;
  }
  files_.push_back(std::move(f));
}

void Ros2Bag::count_messages() {
  std::int64_t first = std::numeric_limits<std::int64_t>::max();
  std::int64_t last = std::numeric_limits<std::int64_t>::min();
  for (const BagFile& f : files_) {
    SqliteStatement st = f.db->prepare(
        "SELECT topic_id, COUNT(*), MIN(timestamp), MAX(timestamp) FROM messages GROUP BY "
        "topic_id");
    while (st.step()) {
      const auto it = f.topic_of_id.find(st.integer(0));
      if (it == f.topic_of_id.end())
        throw InputError(f.db->name() + ": messages of topic id " + std::to_string(st.integer(0)) +
                         ", which the topics table does not list");
      topics_[it->second].count += static_cast<std::size_t>(st.integer(1));
      first = std::min(first, st.integer(2));
      last = std::max(last, st.integer(3));
    }
  }
  if (first <= last) {
    info_.start = static_cast<double>(first) * 1e-9;
    info_.end = static_cast<double>(last) * 1e-9;
  }
}

void Ros2Bag::find_frames() {
  std::vector<std::uint8_t> scratch;
  for (std::size_t ti = 0; ti < topics_.size(); ++ti) {
    Topic& t = topics_[ti];
    if (t.kind == Ros2Type::other || t.kind == Ros2Type::tf || t.count == 0) continue;
    check_cdr(t, 0);
    // The topic's first message over all files (split files overlap when recorded with
    // several writers' caches).
    std::int64_t best = std::numeric_limits<std::int64_t>::max();
    for (std::size_t fi = 0; fi < files_.size(); ++fi) {
      for (const auto& [id, index] : files_[fi].topic_of_id) {
        if (index != ti) continue;
        SqliteStatement st = files_[fi].db->prepare(
            "SELECT timestamp, data FROM messages WHERE topic_id = ? ORDER BY timestamp, id "
            "LIMIT 1");
        st.bind(1, id);
        if (!st.step() || st.integer(0) >= best) continue;
        best = st.integer(0);
        const std::string w = where(fi, t, best);
        std::size_t size = 0;
        const std::uint8_t* p = body(st, 1, w, scratch, size);
        t.frame_id = ros2_header_frame(t.kind, p, size, w);
      }
    }
  }
}

std::string Ros2Bag::where(std::size_t file, const Topic& topic, std::int64_t ns) const {
  return files_[file].db->name() + ": topic " + topic.name + ", message at " + seconds(ns) + " s";
}

const std::uint8_t* Ros2Bag::body(const SqliteStatement& st, int column, const std::string& where,
                                  std::vector<std::uint8_t>& scratch, std::size_t& size) const {
  const std::uint8_t* p = st.blob(column, size);
  if (compression_ != Ros2Compression::zstd_message) return p;
  scratch = zstd_decompress(p, size, where);
  size = scratch.size();
  return scratch.data();
}

void Ros2Bag::check_cdr(const Topic& t, std::size_t file) const {
  if (t.serialization != "cdr")
    throw InputError(files_[file].db->name() + ": topic " + t.name + " is serialised as '" +
                     t.serialization + "', not CDR");
}

void Ros2Bag::read(const std::vector<std::string>& topics, const BagHandlers& handlers) {
  std::vector<Cursor> cursors;
  for (std::size_t fi = 0; fi < files_.size(); ++fi) {
    std::string ids;
    for (const auto& [id, index] : files_[fi].topic_of_id) {
      const Topic& t = topics_[index];
      if (t.kind == Ros2Type::other ||
          std::find(topics.begin(), topics.end(), t.name) == topics.end())
        continue;
      check_cdr(t, fi);
      ids += (ids.empty() ? "" : ",") + std::to_string(id);
    }
    if (ids.empty()) continue;
    Cursor c{fi,
             files_[fi].db->prepare("SELECT id, topic_id, timestamp, data FROM messages WHERE "
                                    "topic_id IN (" +
                                    ids + ") ORDER BY timestamp, id"),
             false};
    c.live = c.st.step();
    if (c.live) cursors.push_back(std::move(c));
  }
  std::vector<std::uint8_t> scratch;
  for (;;) {
    Cursor* next = nullptr;  // the earliest message; ties go to the earlier file
    for (Cursor& c : cursors)
      if (c.live && (!next || c.st.integer(2) < next->st.integer(2))) next = &c;
    if (!next) break;
    const std::int64_t id = next->st.integer(0);
    if (id < 0 || static_cast<std::uint64_t>(id) > kIdMask)
      throw InputError(files_[next->file].db->name() + ": message id " + std::to_string(id) +
                       " is out of range");
    const Topic& t = topics_[files_[next->file].topic_of_id.at(next->st.integer(1))];
    const std::string w = where(next->file, t, next->st.integer(2));
    std::size_t size = 0;
    const std::uint8_t* p = body(next->st, 3, w, scratch, size);
    const std::uint64_t key =
        (static_cast<std::uint64_t>(next->file) << kFileShift) | static_cast<std::uint64_t>(id);
    decode_ros2_message(t.kind, p, size, w, t.name, key, handlers);
    next->live = next->st.step();
  }
}

CloudMsg Ros2Bag::read_cloud(const std::string& topic, std::uint64_t key) {
  const std::uint64_t file = key >> kFileShift;
  if (file >= files_.size())
    throw InputError("ROS 2 bag: cloud key " + std::to_string(key) + " names file " +
                     std::to_string(file) + " of " + std::to_string(files_.size()));
  const BagFile& f = files_[file];
  SqliteStatement st = f.db->prepare("SELECT topic_id, timestamp, data FROM messages WHERE id = ?");
  st.bind(1, static_cast<std::int64_t>(key & kIdMask));
  if (!st.step())
    throw InputError(f.db->name() + ": no message with id " + std::to_string(key & kIdMask));
  const auto it = f.topic_of_id.find(st.integer(0));
  if (it == f.topic_of_id.end() || topics_[it->second].name != topic ||
      topics_[it->second].kind != Ros2Type::point_cloud2)
    throw InputError(f.db->name() + ": message " + std::to_string(key & kIdMask) +
                     " is not a PointCloud2 of topic " + topic);
  const Topic& t = topics_[it->second];
  const std::string w = where(file, t, st.integer(1));
  std::vector<std::uint8_t> scratch;
  std::size_t size = 0;
  const std::uint8_t* p = body(st, 2, w, scratch, size);
  return decode_ros2_cloud(p, size, w);
}

}  // namespace

std::unique_ptr<BagSource> open_ros2_bag(const std::string& path) {
  return std::make_unique<Ros2Bag>(path);
}

}  // namespace potmap::data
