// The program binary cache under faults: a damaged entry (bytes changed, truncated), an entry
// the driver rejects, an entry of an older format and a folder that cannot be used must each
// end in a working program built from source, with one warning where something was wrong.
#include <gtest/gtest.h>

#include <unistd.h>

#include <sys/stat.h>
#include <chrono>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>

#include "potmap/runtime/context.hpp"
#include "runtime/hash.hpp"
#include "test_support.hpp"

using namespace potmap;
namespace fs = std::filesystem;

namespace {

constexpr std::size_t kMagicBytes = 19;  // "POTMAP-CL-BINARY-2\n"

// A source no other test builds (PoCL's own cache never answers for it either).
std::string fresh_source(const char* name) {
  return "// " + std::to_string(std::chrono::steady_clock::now().time_since_epoch().count()) +
         "\n__kernel void " + name + "(__global int* x) { x[get_global_id(0)] = 3; }";
}

struct Build {
  std::size_t from_source = 0, hits = 0;
  std::string warnings;  // what went to stderr
};

// One fresh Context on `dir` building `src`, as a later run of the command would.
Build build(const std::string& dir, const std::string& src) {
  ContextOptions o;
  o.binary_cache_dir = dir;
  testing::internal::CaptureStderr();
  Build b;
  {
    Context ctx(o);
    ctx.program_from_source("k", src);
    b.from_source = ctx.builds_from_source();
    b.hits = ctx.disk_cache_hits();
  }
  b.warnings = testing::internal::GetCapturedStderr();
  return b;
}

// The one entry in `dir` (built by build()).
std::string only_entry(const std::string& dir) {
  std::string found;
  for (const auto& e : fs::directory_iterator(dir))
    if (e.path().extension() == ".clbin") {
      EXPECT_TRUE(found.empty()) << "more than one entry in " << dir;
      found = e.path().string();
    }
  EXPECT_FALSE(found.empty()) << "no entry in " << dir;
  return found;
}

void write_bytes(const std::string& path, const std::string& bytes) {
  std::ofstream(path, std::ios::binary | std::ios::trunc) << bytes;
}

// Where the binary starts in an entry: magic, key length, key, binary length, checksum.
std::size_t binary_offset(const std::string& entry) {
  std::uint64_t key_len = 0;
  std::memcpy(&key_len, entry.data() + kMagicBytes, 8);
  return kMagicBytes + 8 + key_len + 16;
}

// A damaged entry: rebuilt from source with a warning naming it, then stored afresh (the next
// run hits again, quietly).
void expect_rebuilt_with_warning(const std::string& dir, const std::string& src,
                                 const std::string& why) {
  const std::string entry = only_entry(dir);
  const Build b = build(dir, src);
  EXPECT_EQ(b.from_source, 1u);
  EXPECT_EQ(b.hits, 0u);
  EXPECT_NE(b.warnings.find("warning: kernel binary cache entry '" + entry + "'"),
            std::string::npos)
      << b.warnings;
  EXPECT_NE(b.warnings.find(why), std::string::npos) << b.warnings;
  EXPECT_NE(b.warnings.find("rebuilding from source"), std::string::npos) << b.warnings;
  const Build again = build(dir, src);
  EXPECT_EQ(again.hits, 1u) << "the rebuilt binary was not stored again";
  EXPECT_EQ(again.warnings, "");
}

}  // namespace

TEST(BinaryCache, AHealthyEntryIsUsedQuietly) {
  const std::string dir = test::temp_dir("bincache-healthy");
  const std::string src = fresh_source("healthy");
  const Build first = build(dir, src);
  EXPECT_EQ(first.from_source, 1u);
  EXPECT_EQ(first.warnings, "");
  const Build second = build(dir, src);
  EXPECT_EQ(second.from_source, 0u);
  EXPECT_EQ(second.hits, 1u);
  EXPECT_EQ(second.warnings, "");
}

TEST(BinaryCache, ABinaryWithChangedBytesFailsItsChecksum) {
  const std::string dir = test::temp_dir("bincache-flipped");
  const std::string src = fresh_source("flipped");
  build(dir, src);
  const std::string entry = only_entry(dir);
  std::string bytes = test::file_bytes(entry);
  const std::size_t at = binary_offset(bytes);
  ASSERT_LT(at, bytes.size());
  bytes[at + (bytes.size() - at) / 2] ^= 0x5a;  // one byte in the middle of the binary
  write_bytes(entry, bytes);
  expect_rebuilt_with_warning(dir, src, "fails its checksum");
}

TEST(BinaryCache, ATruncatedEntryIsRebuilt) {
  const std::string dir = test::temp_dir("bincache-truncated");
  const std::string src = fresh_source("truncated");
  build(dir, src);
  const std::string entry = only_entry(dir);
  const std::string bytes = test::file_bytes(entry);
  write_bytes(entry, bytes.substr(0, binary_offset(bytes) + 10));  // inside the binary
  expect_rebuilt_with_warning(dir, src, "truncated");
  write_bytes(only_entry(dir), bytes.substr(0, kMagicBytes + 4));  // inside the header
  expect_rebuilt_with_warning(dir, src, "truncated");
  write_bytes(only_entry(dir), "garbage");  // not an entry at all
  expect_rebuilt_with_warning(dir, src, "not a potmap cache entry");
}

TEST(BinaryCache, ABinaryTheDriverRejectsFallsBackToSource) {
  const std::string dir = test::temp_dir("bincache-rejected");
  const std::string src = fresh_source("rejected");
  build(dir, src);
  const std::string entry = only_entry(dir);
  std::string bytes = test::file_bytes(entry);
  const std::size_t at = binary_offset(bytes);
  // Junk of the same length with a matching checksum: only the driver can tell.
  std::string junk(bytes.size() - at, '\0');
  for (std::size_t i = 0; i < junk.size(); ++i) junk[i] = static_cast<char>(i * 37 + 11);
  const std::uint64_t sum = detail::fnv1a64(junk);
  bytes.replace(at - 8, 8, reinterpret_cast<const char*>(&sum), 8);
  bytes.replace(at, junk.size(), junk);
  write_bytes(entry, bytes);
  expect_rebuilt_with_warning(dir, src, "rejected by the driver");
}

TEST(BinaryCache, AnEntryOfTheOlderFormatIsAQuietMiss) {
  const std::string dir = test::temp_dir("bincache-v1");
  const std::string src = fresh_source("older");
  build(dir, src);
  const std::string entry = only_entry(dir);
  std::string bytes = test::file_bytes(entry);
  bytes[kMagicBytes - 2] = '1';  // "POTMAP-CL-BINARY-1\n": written by an older potmap
  write_bytes(entry, bytes);
  const Build b = build(dir, src);
  EXPECT_EQ(b.from_source, 1u);
  EXPECT_EQ(b.warnings, "");
  EXPECT_EQ(build(dir, src).hits, 1u) << "the rebuilt binary replaces the stale entry";
}

TEST(BinaryCache, AFileWhereTheFolderShouldBeDisablesTheCacheOnce) {
  const std::string dir = test::temp_dir("bincache-file");
  const std::string blocked = dir + "/cache";
  write_bytes(blocked, "not a folder");
  ContextOptions o;
  o.binary_cache_dir = blocked;
  testing::internal::CaptureStderr();
  {
    Context ctx(o);
    ctx.program_from_source("a", fresh_source("blocked_a"));
    ctx.program_from_source("b", fresh_source("blocked_b"));
    EXPECT_EQ(ctx.builds_from_source(), 2u);
  }
  const std::string err = testing::internal::GetCapturedStderr();
  const std::string warning = "kernel binary cache at '" + blocked + "' disabled";
  const std::size_t first = err.find(warning);
  EXPECT_NE(first, std::string::npos) << err;
  EXPECT_EQ(err.find(warning, first + 1), std::string::npos) << "more than one warning: " << err;
  EXPECT_EQ(test::file_bytes(blocked), "not a folder");
}

// chmod 000 denies nothing to root (as CI and this machine run the tests): the folder is made
// unusable by mode where that works, and by a file inside its path where it does not, so that
// the same behaviour is checked either way.
TEST(BinaryCache, AnUnreadableFolderFallsBackToNoCache) {
  const std::string dir = test::temp_dir("bincache-unreadable");
  std::string cache = dir + "/cache";
  fs::create_directories(cache);
  ::chmod(cache.c_str(), 0);
  const bool mode_denies = ::access(cache.c_str(), R_OK | W_OK) != 0;
  if (!mode_denies) cache = dir + "/cache-under-a-file/sub";
  if (!mode_denies) write_bytes(dir + "/cache-under-a-file", "x");
  ContextOptions o;
  o.binary_cache_dir = cache;
  testing::internal::CaptureStderr();
  std::size_t from_source = 0;
  {
    Context ctx(o);
    ctx.program_from_source("u", fresh_source("unreadable"));
    from_source = ctx.builds_from_source();
  }
  const std::string err = testing::internal::GetCapturedStderr();
  ::chmod((dir + "/cache").c_str(), 0755);
  EXPECT_EQ(from_source, 1u);
  EXPECT_NE(err.find("kernel binary cache at '" + cache + "' disabled"), std::string::npos) << err;
}
