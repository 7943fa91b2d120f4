// potmap dict build / info on a simulated town with a BHM map learned over it.
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <filesystem>

#include "potmap/pot/dictionary_io.hpp"
#include "test_support.hpp"

namespace fs = std::filesystem;
using namespace potmap;

TEST(DictCli, BuildFromSimulatedTownAndInfo) {
  if (!test::cli_built()) GTEST_SKIP() << "potmap command not built";
  const std::string dir = test::temp_dir("dict_cli");
  const std::string q = test::quoted(dir);
  test::CliResult r =
      test::run_cli("data simulate --town town1 --seed 2 --scans 12 --out " + q, "2>&1");
  ASSERT_EQ(r.status, 0) << r.out;
  r = test::run_cli("learn bhm " + test::quoted(dir + "/train.csv") + " -o " +
                        test::quoted(dir + "/bhm.potmap") + " --cpu --em 1",
                    "2>&1");
  ASSERT_EQ(r.status, 0) << r.out;

  const std::string dict = dir + "/town1.potdict";
  r = test::run_cli("dict build --scans " + test::quoted(dir + "/scans.log") + " --map " +
                        test::quoted(dir + "/bhm.potmap") + " --out " + test::quoted(dict) +
                        " --sectors 4 --first 2 --scans-limit 8 --json -",
                    "2>/dev/null");
  ASSERT_EQ(r.status, 0) << r.out;
  const nlohmann::json built = nlohmann::json::parse(r.out);
  const Dictionary d = read_dictionary(dict);
  EXPECT_EQ(built["atoms"].get<std::size_t>(), d.size());
  // 8 scans of 4 sectors in a street: nearly every sector sees enough to become an atom.
  EXPECT_GE(d.size(), 24u);
  EXPECT_LE(d.size(), 32u);
  EXPECT_EQ(d.sectors, 4);
  EXPECT_DOUBLE_EQ(d.max_range, 20.0);
  std::size_t kernels = 0;
  for (const Atom& a : d.atoms) {
    EXPECT_GE(a.scan_index, 2);  // indices in the dataset, not in the chunk
    EXPECT_LE(a.scan_index, 9);
    EXPECT_GE(a.kernels.size(), 1u);
    kernels += a.kernels.size();
  }
  EXPECT_EQ(built["kernels"].get<std::size_t>(), kernels);
  EXPECT_EQ(d.atoms[0].source, "scans.log + bhm.potmap");

  r = test::run_cli("dict info " + test::quoted(dict), "2>&1");
  ASSERT_EQ(r.status, 0) << r.out;
  EXPECT_NE(r.out.find("atoms             " + std::to_string(d.size())), std::string::npos)
      << r.out;
  EXPECT_NE(r.out.find("kernels per atom"), std::string::npos) << r.out;
  r = test::run_cli("dict info " + test::quoted(dict) + " --json -", "2>/dev/null");
  ASSERT_EQ(r.status, 0) << r.out;
  const nlohmann::json info = nlohmann::json::parse(r.out);
  EXPECT_EQ(info["atoms"], built["atoms"]);
  EXPECT_EQ(info["hits_per_atom"], built["hits_per_atom"]);
  EXPECT_EQ(info["bytes"].get<std::size_t>(), fs::file_size(dict));

  // Errors name the file.
  r = test::run_cli("dict info " + test::quoted(dir + "/bhm.potmap"), "2>&1");
  EXPECT_EQ(r.status, 1);
  EXPECT_NE(r.out.find("bhm.potmap: byte offset 0: not a potmap dictionary"), std::string::npos)
      << r.out;
  r = test::run_cli("dict build --scans " + test::quoted(dir + "/scans.log") + " --map " +
                        test::quoted(dir + "/bhm.potmap") + " --out " +
                        test::quoted(dir + "/x.potdict") + " --first 99",
                    "2>&1");
  EXPECT_EQ(r.status, 1);
  EXPECT_NE(r.out.find("--first 99"), std::string::npos) << r.out;

  // Merge: a second place's dictionary (same radius and scale) appended, coverage per source.
  const std::string second = dir + "/second.potdict";
  r = test::run_cli("dict build --scans " + test::quoted(dir + "/scans.log") + " --map " +
                        test::quoted(dir + "/bhm.potmap") + " --out " + test::quoted(second) +
                        " --first 10 --source other",
                    "2>&1");
  ASSERT_EQ(r.status, 0) << r.out;
  const Dictionary d2 = read_dictionary(second);
  const std::string both = dir + "/both.potdict";
  r = test::run_cli("dict merge " + test::quoted(dict) + " " + test::quoted(second) + " --out " +
                        test::quoted(both) + " --json -",
                    "2>/dev/null");
  ASSERT_EQ(r.status, 0) << r.out;
  const Dictionary m = read_dictionary(both);
  ASSERT_EQ(m.size(), d.size() + d2.size());
  EXPECT_EQ(m.atoms.front().source, d.atoms.front().source);
  EXPECT_EQ(m.atoms.back().source, "other");
  EXPECT_EQ(m.sectors, 5);  // the larger of 4 and the default 5
  r = test::run_cli("dict info " + test::quoted(both) + " --json -", "2>/dev/null");
  ASSERT_EQ(r.status, 0) << r.out;
  const nlohmann::json mi = nlohmann::json::parse(r.out);
  EXPECT_EQ(mi["sources"]["other"]["atoms"].get<std::size_t>(), d2.size());
  EXPECT_EQ(mi["sources"]["other"]["scan_index"]["min"].get<long>(), 10);
  EXPECT_GT(mi["memory_bytes_per_atom"].get<double>(), 0);
  EXPECT_GT(mi["index_bytes_per_atom"].get<double>(), 0);
  EXPECT_GE(mi["load_ms"].get<double>(), 0);
  // Another scale cannot be merged; the error names the file.
  const std::string scaled = dir + "/scaled.potdict";
  r = test::run_cli("dict build --scans " + test::quoted(dir + "/scans.log") + " --map " +
                        test::quoted(dir + "/bhm.potmap") + " --out " + test::quoted(scaled) +
                        " --first 10 --scale 0.01",
                    "2>&1");
  ASSERT_EQ(r.status, 0) << r.out;
  r = test::run_cli("dict merge " + test::quoted(dict) + " " + test::quoted(scaled) + " --out " +
                        test::quoted(dir + "/bad.potdict"),
                    "2>&1");
  EXPECT_EQ(r.status, 1);
  EXPECT_NE(r.out.find("scaled.potdict: merge_dictionary"), std::string::npos) << r.out;
  EXPECT_FALSE(fs::exists(dir + "/bad.potdict"));
}
