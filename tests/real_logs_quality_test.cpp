// Map quality on the four real Radish logs, through `potmap experiment` as a user runs it (the
// committed runs' settings, fewer scans): held-out beams, 20 m cut, first 10 scans the source.
// Thresholds are the values measured on these cases (docs/results.md has the full runs) less an
// honest margin, so that a return to lattice-of-dots BHM maps or blob POT maps fails here: the
// structural F1 of the blob maps was 0.18-0.26, their NLL above 0.693.
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <fstream>
#include <map>
#include <string>
#include <vector>

#include "test_support.hpp"

namespace {

namespace test = potmap::test;
using nlohmann::json;

// RePOT's seeds yield fully by default: near the data its map is BHM's up to the conjugate
// gradients' rounding, which moves the held-out scores by about 1e-8.
constexpr double kRounding = 1e-6;

struct Row {
  double acc = 0, auc = 0, nll = 0, f1 = 0;
};

// Table rows by (target, method) of one run.
std::map<std::pair<std::string, std::string>, Row> run_methods(const std::string& name,
                                                               const std::string& args) {
  const std::string dir = potmap::test::temp_dir("real_logs_" + name);
  const std::string js = dir + "/out.json";
  const auto r = potmap::test::run_cli(
      "experiment " + args + " --seeds 0 --ogm-cells 0.1 --json " + potmap::test::quoted(js),
      "2>&1");
  EXPECT_EQ(r.status, 0) << r.out;
  std::map<std::pair<std::string, std::string>, Row> out;
  std::ifstream in(js);
  if (!in) {
    ADD_FAILURE() << "no JSON: " << r.out;
    return out;
  }
  const json j = json::parse(in);
  for (const json& row : j["table"]) {
    Row x;
    x.acc = row["acc"]["mean"].get<double>();
    x.auc = row["auc"]["mean"].get<double>();
    x.nll = row["nll"]["mean"].get<double>();
    x.f1 = row["f1"]["mean"].get<double>();
    const std::string case_name =
        row["source"].get<std::string>() + ">" + row["target"].get<std::string>();
    out[{case_name, row["method"].get<std::string>()}] = x;
  }
  return out;
}

std::string logs(std::initializer_list<const char*> names) {
  std::string s;
  for (const char* n : names)
    s += " " + potmap::test::quoted(
                   potmap::test::shared_data(std::string("radish/") + n + "-corrected.log.gz"));
  return s;
}

// Measured (40 scans, seed 0), BHM / OGM AUC: intel 0.980/0.939, aces 0.980/0.938, csail
// 0.971/0.943, freiburg 0.991/0.978; NLL BHM 0.11-0.18, OGM 0.20-0.30; F1 BHM 0.59-0.83.
// POT (kernels on the target's samples, solved together, logits times 1.5, averaged overall
// map): AUC intel 0.956, aces 0.961, csail 0.944, freiburg 0.981; NLL 0.189, 0.206, 0.246,
// 0.163; F1 0.466, 0.425, 0.700, 0.551. Each class's partition with gain 1 and free anchors
// 0.5 m clear of hits scored AUC 0.942-0.966, NLL 0.239-0.305 and F1 0.494-0.711: the solve
// buys NLL with thicker walls behind the hits (its larger wall weights reach farther into space
// no beam crossed), which the F1 against a 0.1 m grid counts as lower precision. RePOT against BHM:
// equal to 1e-8 (seeds yield fully; with the seeded start kept, AUC was at least BHM's here and NLL
// 0.001-0.004 below). Small inputs (12 scans, the sanitizer run), measured: BHM AUC 0.971-0.990,
// NLL 0.115-0.189, F1 0.67-0.77; POT AUC 0.946-0.985, NLL 0.152-0.239, F1 0.419-0.510; RePOT AUC =
// BHM's, NLL 0.004-0.010 below, F1 above BHM's. Freiburg is left out there: its first 12 scans see
// one corridor, and the BHM's bias (positive on those scans) puts the unobserved four fifths of the
// window at p 0.6, F1 0.12 (0.09 at 20 scans; the 40-scan figures above are past that).
TEST(RealLogs, IntraDomainMapsDepictThePlace) {
  const std::vector<const char*> targets =
      test::small_inputs() ? std::vector<const char*>{"intel", "aces", "csail"}
                           : std::vector<const char*>{"intel", "aces", "csail", "freiburg-079"};
  std::string paths;
  for (const char* t : targets) paths += logs({t});
  const int scans = test::sized(40, 12);
  const auto rows = run_methods("intra", "intra" + paths + " --scans " + std::to_string(scans) +
                                             " --methods ogm,bhm,pot,repot");
  for (const char* t : targets) {
    const std::string c = std::string(t) + ">" + t;
    ASSERT_TRUE(rows.count({c, "BHM"}) && rows.count({c, "POT"}) && rows.count({c, "RePOT"}) &&
                rows.count({c, "OGM"}))
        << t;
    const Row& ogm = rows.at({c, "OGM"});
    const Row& bhm = rows.at({c, "BHM"});
    const Row& pot = rows.at({c, "POT"});
    const Row& repot = rows.at({c, "RePOT"});
    // BHM: continuous and calibrated, above the grid.
    EXPECT_GT(bhm.auc, 0.96) << t;
    EXPECT_LT(bhm.nll, 0.20) << t;
    EXPECT_GT(bhm.auc, ogm.auc) << t;
    EXPECT_LT(bhm.nll, ogm.nll) << t;
    EXPECT_GT(bhm.f1, 0.5) << t;
    // POT: never confidently wrong; walls where the place has them.
    EXPECT_GT(pot.auc, test::sized(0.935, 0.935)) << t;
    EXPECT_LT(pot.nll, test::sized(0.27, 0.26)) << t;
    EXPECT_GT(pot.f1, test::sized(0.40, 0.38)) << t;
    // RePOT: at least the BHM it refines (seeds yield fully: equal up to the solver's
    // rounding, about 1e-8 here).
    EXPECT_GE(repot.auc, bhm.auc - kRounding) << t;
    EXPECT_LE(repot.nll, bhm.nll + kRounding) << t;
    EXPECT_GT(repot.f1, 0.5) << t;
  }
}

// Measured (30 scans, seed 0): intel -> csail POT AUC 0.934 NLL 0.274 F1 0.64; csail -> intel
// 0.945 / 0.237 / 0.52 (before kernels on the target's samples and the averaged overall map:
// 0.867 / 0.359 / 0.60 and 0.934 / 0.261 / 0.54). Small inputs (12 scans): 0.947 / 0.229 / 0.58
// and 0.969 / 0.232 / 0.44. RePOT against BHM: equal to 1e-8 (with the seeded start kept, AUC
// equal to 4 digits and NLL up to 0.004 below).
TEST(RealLogs, InterDomainTransferIsNeverConfidentlyWrong) {
  const int scans = test::sized(30, 12);
  const auto rows = run_methods("inter", "inter" + logs({"intel", "csail"}) + " --scans " +
                                             std::to_string(scans) + " --methods bhm,pot,repot");
  for (const char* c : {"intel>csail", "csail>intel"}) {
    ASSERT_TRUE(rows.count({c, "BHM"}) && rows.count({c, "POT"}) && rows.count({c, "RePOT"})) << c;
    const Row& bhm = rows.at({c, "BHM"});
    const Row& pot = rows.at({c, "POT"});
    const Row& repot = rows.at({c, "RePOT"});
    EXPECT_GT(pot.auc, 0.92) << c;
    EXPECT_LT(pot.nll, 0.31) << c;
    EXPECT_GT(pot.f1, test::sized(0.45, 0.40)) << c;
    EXPECT_GE(repot.auc, bhm.auc - kRounding) << c;
    EXPECT_LE(repot.nll, bhm.nll + kRounding) << c;
  }
}

// Atoms from the simulated towns on real logs: the source least like the target, where RePOT
// with the seeded start kept lost to BHM (measured, 12 scans, seed 0: aces AUC -0.0087, NLL
// +0.018 against BHM; csail AUC -0.0003). With the default rule the two maps are the same near
// the data: measured equal to 1e-8 on both logs.
TEST(RealLogs, SimToRealRePOTIsNeverBelowBHM) {
  const auto rows = run_methods("sim2real", "sim2real" + logs({"aces", "csail"}) +
                                                " --scans 12 --atom-scans 4 --methods bhm,repot");
  for (const char* c : {"sim:town1+town2+town3>aces", "sim:town1+town2+town3>csail"}) {
    ASSERT_TRUE(rows.count({c, "BHM"}) && rows.count({c, "RePOT"})) << c;
    const Row& bhm = rows.at({c, "BHM"});
    const Row& repot = rows.at({c, "RePOT"});
    EXPECT_GT(bhm.auc, 0.93) << c;
    EXPECT_GE(repot.auc, bhm.auc - kRounding) << c;
    EXPECT_LE(repot.nll, bhm.nll + kRounding) << c;
  }
}

}  // namespace
