#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "potmap/error.hpp"
#include "potmap/map/metrics.hpp"

using namespace potmap;
using V = std::vector<double>;
using L = std::vector<std::uint8_t>;

TEST(Metrics, PerfectAndInvertedClassifiers) {
  const V p = {0.1, 0.2, 0.7, 0.9};
  const L y = {0, 0, 1, 1};
  Scores s = score(p, y);
  EXPECT_EQ(s.n, 4u);
  EXPECT_DOUBLE_EQ(s.acc, 1.0);
  EXPECT_DOUBLE_EQ(s.auc, 1.0);
  EXPECT_NEAR(s.nll, -(std::log(0.9) + std::log(0.8) + std::log(0.7) + std::log(0.9)) / 4, 1e-12);
  s = score(p, L{1, 1, 0, 0});
  EXPECT_DOUBLE_EQ(s.acc, 0.0);
  EXPECT_DOUBLE_EQ(s.auc, 0.0);
}

TEST(Metrics, AucCountsTiesAsHalf) {
  // Pairs (occupied, free): 0.4 vs 0.1 wins, 0.4 vs 0.4 ties, 0.8 wins twice: 3.5 / 4.
  EXPECT_DOUBLE_EQ(roc_auc(V{0.1, 0.4, 0.4, 0.8}, L{0, 0, 1, 1}), 0.875);
  EXPECT_DOUBLE_EQ(roc_auc(V{0.5, 0.5, 0.5, 0.5, 0.5}, L{1, 0, 1, 0, 0}), 0.5);
  // Three occupied, two free, one tie group spanning both classes: (1 + 1 + 0.5 + 0.5 + 0 + 0)/6.
  EXPECT_DOUBLE_EQ(roc_auc(V{0.9, 0.3, 0.3, 0.3, 0.1}, L{1, 1, 0, 0, 1}),
                   (1 + 0.5 + 0.5 + 1 + 0) / 6.0);
}

TEST(Metrics, AucMatchesPairCountingOnRandomTies) {
  std::mt19937 rng(3);
  for (int trial = 0; trial < 20; ++trial) {
    const std::size_t n = 50 + rng() % 200;
    V p(n);
    L y(n);
    for (std::size_t i = 0; i < n; ++i) {
      p[i] = (rng() % 11) / 10.0;  // few distinct values: many ties
      y[i] = (rng() % 3 == 0) || p[i] > 0.8;
    }
    double wins = 0, pairs = 0;
    for (std::size_t i = 0; i < n; ++i)
      for (std::size_t j = 0; j < n; ++j)
        if (y[i] == 1 && y[j] == 0) {
          pairs += 1;
          wins += p[i] > p[j] ? 1.0 : p[i] == p[j] ? 0.5 : 0.0;
        }
    EXPECT_NEAR(roc_auc(p, y), wins / pairs, 1e-14) << "trial " << trial;
  }
}

TEST(Metrics, AccuracyTieRuleHalfIsOccupied) {
  EXPECT_DOUBLE_EQ(accuracy(V{0.5}, L{1}), 1.0);
  EXPECT_DOUBLE_EQ(accuracy(V{0.5}, L{0}), 0.0);
  EXPECT_DOUBLE_EQ(accuracy(V{std::nextafter(0.5, 0.0)}, L{0}), 1.0);
}

TEST(Metrics, NllClipsProbabilities) {
  const double worst = -std::log(1e-6);  // 13.8155...
  EXPECT_NEAR(mean_nll(V{0.0}, L{1}), worst, 1e-9);
  EXPECT_NEAR(mean_nll(V{1.0}, L{0}), worst, 1e-6);
  EXPECT_NEAR(mean_nll(V{1.0}, L{1}), 1e-6, 1e-9);
  EXPECT_NEAR(mean_nll(V{0.0, 0.25}, L{1, 0}), (worst - std::log(0.75)) / 2, 1e-9);
  EXPECT_DOUBLE_EQ(kNllClip, 1e-6);
}

TEST(Metrics, OneClassAndEmpty) {
  const Scores s = score(V{0.2, 0.9}, L{1, 1});
  EXPECT_TRUE(std::isnan(s.auc));
  EXPECT_DOUBLE_EQ(s.acc, 0.5);
  const Scores e = score(V{}, L{});
  EXPECT_EQ(e.n, 0u);
  EXPECT_TRUE(std::isnan(e.acc) && std::isnan(e.auc) && std::isnan(e.nll));
}

TEST(Metrics, FloatAndDoubleAgree) {
  const std::vector<float> pf = {0.1f, 0.6f, 0.6f, 0.3f};
  const V pd(pf.begin(), pf.end());
  const L y = {0, 1, 0, 1};
  const Scores a = score(pf, y), b = score(pd, y);
  EXPECT_EQ(a.acc, b.acc);
  EXPECT_EQ(a.auc, b.auc);
  EXPECT_EQ(a.nll, b.nll);
}

TEST(Metrics, RejectsBadInput) {
  EXPECT_THROW(score(V{0.1, 0.2}, L{1}), ArgumentError);
  EXPECT_THROW(score(V{0.1}, L{2}), ArgumentError);
  EXPECT_THROW(score(V{1.5}, L{1}), ArgumentError);
  try {
    score(V{0.1, 0.2, NAN, NAN}, L{0, 1, 0, 1});
    FAIL() << "expected ArgumentError";
  } catch (const ArgumentError& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("2 of 4"), std::string::npos) << m;
    EXPECT_NE(m.find("index 2"), std::string::npos) << m;
  }
}
