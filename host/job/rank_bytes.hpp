#pragma once
// What MPI ranks send each other, as bytes: numbers and arrays of them in this machine's byte
// order (the ranks of one job run one build, on one kind of machine), and the held-out samples
// and files they carry. A reader that runs past the end throws: a message cut short is named,
// never read as zeros.
#include <cstdint>
#include <cstring>
#include <string>
#include <type_traits>
#include <vector>

#include "potmap/data/labelled_points.hpp"
#include "potmap/error.hpp"

namespace potmap::job {

class RankBytesOut {
 public:
  template <class T>
  void put(const T& v) {
    static_assert(std::is_trivially_copyable_v<T>);
    bytes_.append(reinterpret_cast<const char*>(&v), sizeof v);
  }
  template <class T>
  void put(const std::vector<T>& v) {
    static_assert(std::is_trivially_copyable_v<T>);
    put(std::uint64_t(v.size()));
    bytes_.append(reinterpret_cast<const char*>(v.data()), v.size() * sizeof(T));
  }
  void put(const std::string& s) {
    put(std::uint64_t(s.size()));
    bytes_.append(s);
  }
  void put(const LabelledPoints& p) {
    put(std::int32_t(p.dim));
    put(p.position);
    put(p.label);
    put(p.scan);
    put(p.weight);
  }
  std::string& bytes() { return bytes_; }

 private:
  std::string bytes_;
};

class RankBytesIn {
 public:
  /// `from` names the sender in errors ("rank 2").
  RankBytesIn(const std::string& bytes, std::string from) : b_(bytes), from_(std::move(from)) {}
  template <class T>
  void get(T& v) {
    static_assert(std::is_trivially_copyable_v<T>);
    std::memcpy(&v, take(sizeof v), sizeof v);
  }
  template <class T>
  void get(std::vector<T>& v) {
    static_assert(std::is_trivially_copyable_v<T>);
    const std::size_t n = count(sizeof(T));
    v.resize(n);
    if (n) std::memcpy(v.data(), take(n * sizeof(T)), n * sizeof(T));
  }
  void get(std::string& s) {
    const std::size_t n = count(1);
    s.assign(take(n), n);
  }
  void get(LabelledPoints& p) {
    std::int32_t dim = 0;
    get(dim);
    p.dim = dim;
    get(p.position);
    get(p.label);
    get(p.scan);
    get(p.weight);
    if (p.position.size() != p.label.size() * std::size_t(dim))
      throw InputError(from_ + ": held-out samples with " + std::to_string(p.position.size()) +
                       " coordinates for " + std::to_string(p.label.size()) + " labels");
  }

 private:
  std::size_t count(std::size_t item) {
    std::uint64_t n = 0;
    get(n);
    if (n > (b_.size() - at_) / item) take(b_.size() - at_ + 1);  // throws
    return std::size_t(n);
  }
  const char* take(std::size_t n) {
    if (n > b_.size() - at_)
      throw InputError(from_ + ": message cut short at byte " + std::to_string(at_) + " of " +
                       std::to_string(b_.size()));
    const char* p = b_.data() + at_;
    at_ += n;
    return p;
  }
  const std::string& b_;
  std::string from_;
  std::size_t at_ = 0;
};

}  // namespace potmap::job
