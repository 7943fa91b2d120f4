#include "map_checkpoint.hpp"

#include <signal.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <filesystem>

#include "potmap/error.hpp"

namespace potmap::job {

namespace {

// Little-endian, whatever the host: a checkpoint may be resumed on another machine.
class Bytes {
 public:
  void u64(std::uint64_t v) {
    for (int i = 0; i < 8; ++i) out += static_cast<char>((v >> (8 * i)) & 0xff);
  }
  void f64(double d) {
    std::uint64_t v;
    std::memcpy(&v, &d, 8);
    u64(v);
  }
  std::string out;
};

class Reader {
 public:
  Reader(const std::string& b, const std::string& path) : b_(b), path_(path) {}
  std::uint64_t u64() {
    need(8, "a number");
    std::uint64_t v = 0;
    for (int i = 0; i < 8; ++i)
      v |= std::uint64_t(static_cast<unsigned char>(b_[at_ + i])) << (8 * i);
    at_ += 8;
    return v;
  }
  double f64() {
    const std::uint64_t v = u64();
    double d;
    std::memcpy(&d, &v, 8);
    return d;
  }
  // A count of items of `each` bytes that must fit what is left.
  std::size_t count(std::size_t each, const char* what) {
    const std::uint64_t n = u64();
    if (n > (b_.size() - at_) / each)
      throw InputError(path_ + ": checkpoint record: " + what + ": count " + std::to_string(n) +
                       " but " + std::to_string(b_.size() - at_) + " bytes left");
    return static_cast<std::size_t>(n);
  }
  std::string text(const char* what) { return raw(count(1, what), what); }
  std::string raw(std::size_t n, const char* what) {
    need(n, what);
    std::string s = b_.substr(at_, n);
    at_ += n;
    return s;
  }
  bool at_end() const { return at_ == b_.size(); }
  void done() const {
    if (at_ != b_.size())
      throw InputError(path_ + ": checkpoint record: " + std::to_string(b_.size() - at_) +
                       " unread bytes");
  }

 private:
  void need(std::size_t n, const char* what) {
    if (b_.size() - at_ < n)
      throw InputError(path_ + ": checkpoint record: truncated where " + what + " should be");
  }
  const std::string& b_;
  const std::string& path_;
  std::size_t at_ = 0;
};

}  // namespace

std::string encode_checkpoint(const nlohmann::json& run, const MapRunTotals& t, double seconds) {
  Bytes b;
  const std::string r = run.dump();
  b.u64(r.size());
  b.out += r;
  b.u64(t.inst_prob.size());
  for (float p : t.inst_prob) b.f64(p);  // a float is exact as a double
  b.u64(t.labels.size());
  b.out.append(t.labels.begin(), t.labels.end());
  b.u64(static_cast<std::uint64_t>(t.test.dim));
  b.u64(t.test.size());
  for (double x : t.test.position) b.f64(x);
  b.out.append(t.test.label.begin(), t.test.label.end());
  for (std::int64_t s : t.test.scan) b.u64(static_cast<std::uint64_t>(s));
  for (double x : {t.timing.prepare_ms, t.timing.ranking_ms, t.timing.transport_ms,
                   t.timing.placement_ms, t.timing.refine_ms, t.wall_ms, t.max_wall_ms, seconds})
    b.f64(x);
  b.u64(t.kernels);
  b.u64(t.scans);
  // The look-ahead last (records written before it end here and read as none).
  b.u64(t.ahead_prob.size());
  for (float p : t.ahead_prob) b.f64(p);
  b.out.append(t.ahead_label.begin(), t.ahead_label.end());
  b.out.append(t.ahead_beyond.begin(), t.ahead_beyond.end());
  b.f64(t.ahead_ms);
  return std::move(b.out);
}

void decode_checkpoint(const std::string& bytes, const std::string& path, nlohmann::json& run,
                       MapRunTotals& t) {
  Reader r(bytes, path);
  const std::string text = r.text("run record");
  run = nlohmann::json::parse(text, nullptr, false);
  if (run.is_discarded() || !run.is_object())
    throw InputError(path + ": checkpoint record: the run record is not a JSON object");
  t = MapRunTotals();
  t.inst_prob.resize(r.count(8, "instantaneous probabilities"));
  for (float& p : t.inst_prob) p = static_cast<float>(r.f64());
  const std::string labels = r.text("labels");
  t.labels.assign(labels.begin(), labels.end());
  if (t.labels.size() != t.inst_prob.size())
    throw InputError(path + ": checkpoint record: " + std::to_string(t.labels.size()) +
                     " labels for " + std::to_string(t.inst_prob.size()) + " probabilities");
  const std::uint64_t dim = r.u64();
  if (dim != 2 && dim != 3)
    throw InputError(path + ": checkpoint record: held-out samples in " + std::to_string(dim) +
                     "D");
  t.test.dim = static_cast<int>(dim);
  const std::size_t n = r.count(8 * dim + 9, "held-out samples");
  t.test.position.resize(n * dim);
  for (double& x : t.test.position) x = r.f64();
  const std::string test_labels = r.raw(n, "held-out labels");
  t.test.label.assign(test_labels.begin(), test_labels.end());
  t.test.scan.resize(n);
  for (std::int64_t& s : t.test.scan) s = static_cast<std::int64_t>(r.u64());
  double* sums[] = {
      &t.timing.prepare_ms, &t.timing.ranking_ms, &t.timing.transport_ms, &t.timing.placement_ms,
      &t.timing.refine_ms,  &t.wall_ms,           &t.max_wall_ms,         &t.seconds};
  for (double* x : sums) *x = r.f64();
  t.kernels = static_cast<std::size_t>(r.u64());
  t.scans = static_cast<std::size_t>(r.u64());
  if (!r.at_end()) {
    t.ahead_prob.resize(r.count(10, "look-ahead samples"));
    for (float& p : t.ahead_prob) p = static_cast<float>(r.f64());
    const std::string y = r.raw(t.ahead_prob.size(), "look-ahead labels");
    const std::string far = r.raw(t.ahead_prob.size(), "look-ahead reach");
    t.ahead_label.assign(y.begin(), y.end());
    t.ahead_beyond.assign(far.begin(), far.end());
    t.ahead_ms = r.f64();
  }
  r.done();
}

std::size_t remove_stale_temporaries(const std::string& path) {
  namespace fs = std::filesystem;
  const fs::path p(path);
  const fs::path dir = p.parent_path().empty() ? fs::path(".") : p.parent_path();
  const std::string prefix = p.filename().string() + ".tmp-";
  std::size_t removed = 0;
  std::error_code ec;
  for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
    const std::string name = it->path().filename().string();
    if (name.compare(0, prefix.size(), prefix) != 0) continue;
    const long pid = std::strtol(name.c_str() + prefix.size(), nullptr, 10);
    // A process that still runs (or one we may not signal) may be writing it.
    if (pid <= 0 || ::kill(static_cast<pid_t>(pid), 0) == 0 || errno != ESRCH) continue;
    std::error_code rm;
    removed += fs::remove(it->path(), rm) ? 1 : 0;
  }
  return removed;
}

void check_same_run(const std::string& path, const nlohmann::json& saved,
                    const nlohmann::json& run) {
  std::string diff;
  for (const auto& [key, value] : run.items()) {
    const auto it = saved.find(key);
    const std::string was = it == saved.end() ? "nothing" : it->dump();
    if (it == saved.end() || *it != value)
      diff += "\n  " + key + ": the checkpoint has " + was + ", this run " + value.dump();
  }
  for (const auto& [key, value] : saved.items())
    if (!run.contains(key))
      diff += "\n  " + key + ": the checkpoint has " + value.dump() + ", this run nothing";
  if (!diff.empty())
    throw ArgumentError(path +
                        ": the checkpoint is of another run (other input or options); "
                        "drop --resume to start afresh, or give the run's own arguments:" +
                        diff);
}

}  // namespace potmap::job
