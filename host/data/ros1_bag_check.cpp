// A ROS 1 bag's record lengths checked against the file before librosbag_storage reads it:
// the library allocates whatever a header or chunk says it holds, so a truncated or corrupt
// bag would otherwise cost gigabytes before it failed. Only the framing is read here (record
// and field lengths, the chunk sizes and positions), never a message.
#include <cstdint>
#include <cstring>
#include <fstream>
#include <map>
#include <set>
#include <string>

#include "potmap/error.hpp"

namespace potmap::data {

namespace {

constexpr char kMagic[] = "#ROSBAG V2.0\n";
constexpr std::size_t kMagicSize = 13;
// A compressed chunk's stated size against its bytes: lz4 and bz2 on LIDAR data stay far
// below this; a larger claim is a corrupt field, not a chunk.
constexpr std::uint64_t kMaxChunkRatio = 1000;
constexpr std::uint64_t kChunkSlack = 1 << 20;

enum Op : std::uint8_t { kBagHeader = 3, kChunk = 5, kChunkInfo = 6 };

struct Record {
  std::map<std::string, std::string> fields;
  std::uint64_t data_at = 0, data_size = 0, end = 0;
};

// The bytes of a bag read where they are needed: record headers from the file, an uncompressed
// chunk's records from memory, so that a bag of gigabytes is checked in kilobytes.
class Bytes {
 public:
  explicit Bytes(const std::string& path) : in_(path, std::ios::binary) {
    if (!in_) throw InputError(path + ": cannot open file");
    in_.seekg(0, std::ios::end);
    size_ = static_cast<std::uint64_t>(in_.tellg());
  }
  std::uint64_t size() const { return size_; }
  std::string read(std::uint64_t at, std::uint64_t n) {
    std::string out(n, '\0');
    in_.clear();
    in_.seekg(static_cast<std::streamoff>(at));
    in_.read(&out[0], static_cast<std::streamsize>(n));
    out.resize(static_cast<std::size_t>(in_.gcount()));
    return out;
  }

 private:
  std::ifstream in_;
  std::uint64_t size_ = 0;
};

class Walker {
 public:
  Walker(const std::string& path, Bytes& file) : path_(path), file_(file) {}

  std::uint32_t u32(std::uint64_t at, const char* what) const {
    const std::string b = file_.read(at, 4);
    if (b.size() < 4) fail(at, std::string("the file ends inside a ") + what);
    std::uint32_t v;
    std::memcpy(&v, b.data(), 4);
    return v;
  }

  // One record at `at` within [at, limit): its header fields and where its data lies.
  Record record(std::uint64_t at, std::uint64_t limit) const {
    Record r;
    if (limit - at < 4) fail(at, "a record cut short");
    const std::uint64_t header = u32(at, "record header length");
    std::uint64_t p = at + 4;
    if (header > limit - p) fail(at, "a record header of " + std::to_string(header) + " bytes");
    const std::uint64_t header_end = p + header;
    const std::string head = file_.read(p, header);
    if (head.size() < header) fail(at, "the file ends inside a record header");
    for (std::uint64_t q = 0; q < header;) {
      if (header - q < 4) fail(p + q, "a header field cut short");
      std::uint32_t len;
      std::memcpy(&len, head.data() + q, 4);
      q += 4;
      if (len > header - q) fail(p + q - 4, "a header field of " + std::to_string(len) + " bytes");
      const std::string field = head.substr(q, len);
      const std::size_t eq = field.find('=');
      if (eq == std::string::npos) fail(p + q, "a header field without '='");
      r.fields[field.substr(0, eq)] = field.substr(eq + 1);
      q += len;
    }
    if (limit - header_end < 4) fail(header_end, "a record cut short");
    r.data_size = u32(header_end, "record data length");
    r.data_at = header_end + 4;
    if (r.data_size > limit - r.data_at)
      fail(header_end, "record data of " + std::to_string(r.data_size) + " bytes");
    r.end = r.data_at + r.data_size;
    return r;
  }

  template <class T>
  T field(const Record& r, const char* name, std::uint64_t at) const {
    auto it = r.fields.find(name);
    if (it == r.fields.end() || it->second.size() != sizeof(T))
      fail(at, std::string("a record without a ") + std::to_string(sizeof(T)) + "-byte " + name);
    T v;
    std::memcpy(&v, it->second.data(), sizeof(T));
    return v;
  }

  [[noreturn]] void fail(std::uint64_t at, const std::string& what) const {
    throw InputError(path_ + ": not a readable ROS 1 bag: " + what + " at byte " +
                     std::to_string(at) + " of " + std::to_string(file_.size()));
  }

  void check_chunk(const Record& r, std::uint64_t at) const {
    const std::uint32_t size = field<std::uint32_t>(r, "size", at);
    auto c = r.fields.find("compression");
    if (c == r.fields.end()) fail(at, "a chunk without its compression");
    if (c->second == "none") {
      // Its messages are read by offsets into it: their framing must hold too.
      if (size != r.data_size) fail(at, "an uncompressed chunk whose size is not its data's");
      for (std::uint64_t p = r.data_at; p < r.end;) p = record(p, r.end).end;
    } else if (size > kMaxChunkRatio * r.data_size + kChunkSlack) {
      fail(at, "a chunk of " + std::to_string(r.data_size) + " bytes claiming " +
                   std::to_string(size) + " uncompressed");
    }
  }

  void walk() const {
    if (file_.read(0, kMagicSize) != std::string(kMagic, kMagicSize))
      throw InputError(path_ + ": not a ROS 1 bag (it does not start with '#ROSBAG V2.0')");
    std::set<std::uint64_t> chunks;
    std::set<std::uint64_t> chunk_refs;
    for (std::uint64_t at = kMagicSize; at < file_.size();) {
      const Record r = record(at, file_.size());
      const std::uint8_t op = field<std::uint8_t>(r, "op", at);
      if (op == kBagHeader && field<std::uint64_t>(r, "index_pos", at) > file_.size())
        fail(at, "an index position past the end");
      if (op == kChunk) {
        check_chunk(r, at);
        chunks.insert(at);
      }
      if (op == kChunkInfo) chunk_refs.insert(field<std::uint64_t>(r, "chunk_pos", at));
      at = r.end;
    }
    for (std::uint64_t ref : chunk_refs)
      if (!chunks.count(ref)) fail(ref, "a chunk index pointing at no chunk");
  }

 private:
  const std::string& path_;
  Bytes& file_;
};

}  // namespace

void check_ros1_bag_framing(const std::string& path) {
  Bytes file(path);
  Walker(path, file).walk();
}

}  // namespace potmap::data
