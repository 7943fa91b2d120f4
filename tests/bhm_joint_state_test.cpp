// A JointBhm's saved state (learn/bhm_joint_state.hpp) restores the learner bit for bit, in the
// half-stencil layout it writes and in the whole-stencil layout of states saved before it.
#include "learn/bhm_joint_state.hpp"

#include <gtest/gtest.h>

#include <cstdint>
#include <random>
#include <string>
#include <vector>

#include "io/container.hpp"
#include "potmap/error.hpp"
#include "potmap/learn/bhm_joint.hpp"
#include "test_support.hpp"

namespace potmap {
namespace {

using detail::ContainerCursor;
using detail::ContainerLayout;
using detail::ContainerReader;
using detail::ContainerWriter;

constexpr ContainerLayout kTestLayout{"JBHMTEST", "a joint BHM test state", 1, 12,
                                      ContainerLayout::kNoSizeField};

// A corridor's walls at y = +-1.5 over x in [x0, x0 + 6], seen from its axis.
LabelledPoints corridor_scan(std::uint32_t seed, double x0) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0, 1);
  LabelledPoints s;
  s.dim = 2;
  for (int b = 0; b < 80; ++b) {
    const double x = x0 + 6 * u(rng), y = b % 2 ? 1.5 : -1.5;
    s.position.insert(s.position.end(), {x, y});
    s.label.push_back(1);
    const double q = u(rng) * 0.9;
    s.position.insert(s.position.end(), {x, y * q});
    s.label.push_back(0);
  }
  return s;
}

void save(const JointBhm& m, const std::string& path, bool full_stencil) {
  ContainerWriter w(kTestLayout);
  detail::JointBhmState::write(w, m, full_stencil);
  w.finish(path);
}

void restore(const std::string& path, JointBhm& m) {
  const ContainerReader r(path, kTestLayout);
  r.check_checksum();
  ContainerCursor c(r, kTestLayout.header_bytes);
  detail::JointBhmState::read(c, m);
  c.finish();
}

TEST(JointBhmState, RestoresBitForBitFromEitherStencilLayout) {
  const std::string dir = test::temp_dir("joint-bhm-state");
  JointBhm whole(2);
  for (int t = 0; t < 6; ++t) whole.update(corridor_scan(std::uint32_t(t), 2.0 * t));
  JointBhm first(2);
  for (int t = 0; t < 3; ++t) first.update(corridor_scan(std::uint32_t(t), 2.0 * t));
  for (const bool full : {false, true}) {
    SCOPED_TRACE(full ? "whole stencil" : "half stencil");
    const std::string path = dir + (full ? "/full.state" : "/half.state");
    save(first, path, full);
    JointBhm resumed(2);
    restore(path, resumed);
    test::expect_same_map(resumed.map(), first.map());
    for (int t = 3; t < 6; ++t) resumed.update(corridor_scan(std::uint32_t(t), 2.0 * t));
    test::expect_same_map(resumed.map(), whole.map());
  }
}

// A state saved with other options (another kernel width: another stencil) is refused, naming
// what differs.
TEST(JointBhmState, RefusesAnotherStencil) {
  const std::string path = test::temp_dir("joint-bhm-state") + "/other.state";
  JointBhm saved(2);
  saved.update(corridor_scan(1, 0));
  save(saved, path, false);
  JointBhmOptions o;
  o.tau = 18;
  JointBhm other(2, o);
  try {
    restore(path, other);
    FAIL() << "a state of another stencil was read";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("stencil slots"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace potmap
