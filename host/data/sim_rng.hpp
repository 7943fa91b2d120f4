#pragma once
// The seeded generator of the simulator and the labelling (SplitMix64): identical output on
// every standard library, unlike std:: distributions.
#include <cstdint>

namespace potmap::data {
struct SimRng {
  std::uint64_t s;
  std::uint64_t next() {
    std::uint64_t z = (s += 0x9e3779b97f4a7c15ULL);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
    return z ^ (z >> 31);
  }
  double uniform() { return static_cast<double>(next() >> 11) * 0x1.0p-53; }
  double range(double a, double b) { return a + (b - a) * uniform(); }
  /// An integer in [0, n): the same value for every integer type of n.
  template <class T>
  T below(T n) {
    return static_cast<T>(uniform() * n);
  }
};
}  // namespace potmap::data
