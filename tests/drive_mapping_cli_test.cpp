// `potmap mapping DRIVE`: a real 3D drive to a map, an OctoMap, an occupied point cloud, band
// pictures and a ROS map, and scores on held-out beams; a run stopped at a checkpoint and resumed
// ends with the same map and scores as one that ran through.
#include <gtest/gtest.h>
#include <octomap/OcTree.h>
#include <nlohmann/json.hpp>

#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "potmap/io/map_io.hpp"
#include "potmap/pot/dictionary_io.hpp"
#include "test_support.hpp"

namespace fs = std::filesystem;
using namespace potmap;

namespace {

nlohmann::json scores_of(const std::string& dir) {
  return nlohmann::json::parse(test::file_bytes(dir + "/scores.json"));
}

}  // namespace

TEST(DriveMappingCli, LivoxDriveToMapOctomapCloudBandAndScores) {
  if (!test::cli_built()) GTEST_SKIP() << "potmap command not built";
  const std::string d = test::temp_dir("drive-mapping-cli");
  const int keyframes = test::sized(12, 4);
  const test::CliResult r = test::run_cli(
      "mapping " + test::quoted(test::shared_data("drives3d/hku-1")) + " --max-scans " +
          std::to_string(keyframes) + " -q -o " + test::quoted(d) + " --json -",
      "2>/dev/null");
  ASSERT_EQ(r.status, 0) << r.out;
  const nlohmann::json j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["method"], "BHM");
  EXPECT_EQ(j["keyframes"], keyframes);
  EXPECT_EQ(j["range_cut_m"], 40.0);
  // Measured AUC / NLL 0.991 / 0.084 on 12 keyframes, 0.982 / 0.124 on 4 (OctoMap at 0.2 m on
  // keyframes 10-29 of this drive: 0.966 / 0.192, bench/drive3d.py).
  EXPECT_GT(j["scores"]["auc"].get<double>(), test::sized(0.985, 0.975)) << r.out;
  EXPECT_LT(j["scores"]["nll"].get<double>(), test::sized(0.10, 0.14)) << r.out;
  for (const char* f : {"map.potmap", "map.bt", "map_occupied.ply", "map_band_prob.png",
                        "map_band_var.png", "map_band.yaml", "map_band.pgm", "scores.json"})
    EXPECT_TRUE(fs::exists(fs::path(d) / f)) << f;
  // The band's pictures carry their captions (the title with the band's heights, a colour bar,
  // a scale): taller than the band's own pixels, at least as wide.
  const nlohmann::json& band = j["outputs"]["band"];
  ASSERT_EQ(band["picture_px"].size(), 2u) << band;
  for (const char* f : {"/map_band_prob.png", "/map_band_var.png"}) {
    const auto [w, h] = test::png_size(d + f);
    EXPECT_GE(w, band["picture_px"][0].get<std::uint32_t>()) << f;
    EXPECT_GT(h, band["picture_px"][1].get<std::uint32_t>() + 60) << f;
  }
  const KernelMap map = read_map(d + "/map.potmap");
  EXPECT_EQ(map.dim, 3);
  EXPECT_EQ(map.size(), j["kernels"].get<std::size_t>());
  // OctoMap's own reader loads the tree, with occupied and free leaves.
  std::unique_ptr<octomap::AbstractOcTree> any(octomap::AbstractOcTree::read(d + "/map.bt"));
  if (!any) {
    octomap::OcTree t(0.1);
    ASSERT_TRUE(t.readBinary(d + "/map.bt"));
    EXPECT_GT(t.getNumLeafNodes(), 1000u);
  }
  octomap::OcTree tree(0.1);
  ASSERT_TRUE(tree.readBinary(d + "/map.bt"));
  std::size_t occ = 0, fre = 0;
  for (auto it = tree.begin_leafs(); it != tree.end_leafs(); ++it)
    ++(tree.isNodeOccupied(*it) ? occ : fre);
  EXPECT_GT(occ, 100u);
  EXPECT_GT(fre, 100u);
  // The point cloud: a PLY header naming the vertex count the summary gives, and that many
  // records of five floats after it.
  const std::string ply = test::file_bytes(d + "/map_occupied.ply");
  const std::size_t n = j["outputs"]["occupied_voxels"];
  EXPECT_NE(ply.find("element vertex " + std::to_string(n) + "\n"), std::string::npos);
  EXPECT_NE(ply.find("property float probability\nproperty float variance\n"), std::string::npos);
  const std::size_t body = ply.find("end_header\n") + 11;
  EXPECT_EQ(ply.size() - body, n * 5 * sizeof(float));
  // The band's ROS map: free road, occupied sides, unknown beyond (measured 500 / 2,042 / 8,018
  // cells on 4 keyframes, 512 / 2,820 / 9,208 on 12: a walk's band is mostly unknown).
  const std::string pgm = test::file_bytes(d + "/map_band.pgm");
  std::size_t counts[256] = {0};
  for (std::size_t i = pgm.find("\n255\n") + 5; i < pgm.size(); ++i)
    ++counts[static_cast<unsigned char>(pgm[i])];
  EXPECT_GT(counts[0], 400u);
  EXPECT_GT(counts[254], 1500u);
  EXPECT_GT(counts[205], 5000u);
}

TEST(DriveMappingCli, ResumedRunEndsAsAnUninterruptedOne) {
  if (!test::cli_built()) GTEST_SKIP() << "potmap command not built";
  const std::string drive = test::quoted(test::shared_data("drives3d/hku-1"));
  const std::string a = test::temp_dir("drive-resume-a"), b = test::temp_dir("drive-resume-b");
  const std::string common = " --max-scans 8 -q --voxel 0.5";
  // A run that ends after keyframe 4 with its checkpoint at 2 kept: a run stopped there.
  auto stopped_run = [&] {
    return test::run_cli("mapping " + drive + " --max-scans 4 -q --voxel 0.5 " +
                         "--checkpoint-every 2 --keep-checkpoint -o " + test::quoted(b))
        .status;
  };
  ASSERT_EQ(test::run_cli("mapping " + drive + common + " -o " + test::quoted(a)).status, 0);
  ASSERT_EQ(stopped_run(), 0);
  ASSERT_TRUE(fs::exists(b + "/map.ckpt"));
  const test::CliResult r =
      test::run_cli("mapping " + drive + common + " --resume -o " + test::quoted(b));
  ASSERT_EQ(r.status, 0) << r.out;
  EXPECT_NE(r.out.find("resumed        at keyframe 2"), std::string::npos) << r.out;
  EXPECT_FALSE(fs::exists(b + "/map.ckpt"));  // removed once the run is done
  EXPECT_EQ(scores_of(a)["scores"], scores_of(b)["scores"]);
  test::expect_same_map(read_map(a + "/map.potmap"), read_map(b + "/map.potmap"));
  // Another range cut is another run: refused, naming the option.
  ASSERT_EQ(stopped_run(), 0);
  const test::CliResult c =
      test::run_cli("mapping " + drive + common + " --range-cut 30 --resume -o " + test::quoted(b));
  EXPECT_NE(c.status, 0);
  EXPECT_NE(c.out.find("--range-cut"), std::string::npos) << c.out;
}

namespace {

// Starts `potmap mapping` on hku-1 into `dir` in the background, sends `signal` once its
// checkpoint appears, and returns the shell's report of how it ended ("ended 137": killed).
std::string interrupted_run(const std::string& dir, const std::string& args, const char* signal) {
  const std::string cmd = test::quoted(POTMAP_CLI) + " mapping " +
                          test::quoted(test::shared_data("drives3d/hku-1")) + args + " -o " +
                          test::quoted(dir) + " > /dev/null 2>&1 & pid=$!; while [ ! -f " +
                          test::quoted(dir + "/map.ckpt") +
                          " ] && kill -0 $pid 2>/dev/null; do sleep 0.02; done; kill -" + signal +
                          " $pid; wait $pid; echo ended $?";
  std::string out;
  FILE* p = popen(("sh -c " + test::quoted(cmd)).c_str(), "r");
  if (!p) return out;
  char buf[256];
  while (std::fgets(buf, sizeof buf, p)) out += buf;
  pclose(p);
  return out;
}

// Temporary files left in a folder (FILE.tmp-PID...).
std::vector<std::string> temporaries(const std::string& dir) {
  std::vector<std::string> t;
  for (const auto& e : fs::directory_iterator(dir))
    if (e.path().filename().string().find(".tmp-") != std::string::npos)
      t.push_back(e.path().filename().string());
  return t;
}

}  // namespace

TEST(DriveMappingCli, KilledOrInterruptedRunsResumeToTheSameFilesByteForByte) {
  if (!test::cli_built()) GTEST_SKIP() << "potmap command not built";
  const std::string drive = test::quoted(test::shared_data("drives3d/hku-1"));
  const std::string common = " --max-scans 10 --voxel 0.5 --checkpoint-every 2";
  const std::string a = test::temp_dir("drive-kill-a"), b = test::temp_dir("drive-kill-b"),
                    c = test::temp_dir("drive-kill-c");
  ASSERT_EQ(test::run_cli("mapping " + drive + common + " -q -o " + test::quoted(a)).status, 0);
  // SIGKILL once the first checkpoint is there: no chance to clean up, the resumed run does.
  EXPECT_EQ(interrupted_run(b, common, "KILL"), "ended 137\n");
  ASSERT_TRUE(fs::exists(b + "/map.ckpt"));
  // Ctrl-C (SIGINT): the run stops at its next keyframe, exits 130, removes what it was
  // writing and keeps its checkpoint.
  EXPECT_EQ(interrupted_run(c, common, "INT"), "ended 130\n");
  ASSERT_TRUE(fs::exists(c + "/map.ckpt"));
  EXPECT_EQ(temporaries(c), std::vector<std::string>{});
  for (const std::string& d : {b, c}) {
    const test::CliResult r =
        test::run_cli("mapping " + drive + common + " -q --resume -o " + test::quoted(d));
    ASSERT_EQ(r.status, 0) << r.out;
    EXPECT_NE(r.out.find("resumed        at keyframe"), std::string::npos) << r.out;
    EXPECT_EQ(temporaries(d), std::vector<std::string>{}) << d;
    for (const char* f : {"map.potmap", "map.bt", "map_occupied.ply", "map_band.pgm"})
      EXPECT_TRUE(test::file_bytes(a + "/" + f) == test::file_bytes(d + "/" + f)) << d << " " << f;
  }
}

TEST(DriveMappingCli, ExportsWhileMappingLeaveTheFinalFilesAsTheyAre) {
  if (!test::cli_built()) GTEST_SKIP() << "potmap command not built";
  const std::string drive = test::quoted(test::shared_data("drives3d/hku-1"));
  const std::string a = test::temp_dir("drive-export-a"), b = test::temp_dir("drive-export-b");
  const std::string common = " --max-scans 7 --voxel 0.5 --checkpoint-seconds 0";
  ASSERT_EQ(test::run_cli("mapping " + drive + common + " -q -o " + test::quoted(a)).status, 0);
  const test::CliResult r =
      test::run_cli("mapping " + drive + common + " --export-every 3 -o " + test::quoted(b));
  ASSERT_EQ(r.status, 0) << r.out;
  EXPECT_NE(r.out.find("exported       after keyframe 3:"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("exported       after keyframe 6:"), std::string::npos) << r.out;
  for (const char* f : {"map.potmap", "map.bt", "map_occupied.ply", "map_band.pgm"})
    EXPECT_TRUE(test::file_bytes(a + "/" + f) == test::file_bytes(b + "/" + f)) << f;
}

TEST(DriveMappingCli, RefusesPotOnADriveAndNamesABadPoseLine) {
  if (!test::cli_built()) GTEST_SKIP() << "potmap command not built";
  const test::CliResult r = test::run_cli(
      "mapping " + test::quoted(test::shared_data("drives3d/hku-1")) + " --method pot -q");
  EXPECT_NE(r.status, 0);
  EXPECT_NE(r.out.find("--method bhm"), std::string::npos) << r.out;
  // A copy of two keyframes with the second pose broken.
  const std::string d = test::temp_dir("drive-bad-pose");
  fs::create_directories(d + "/Scans");
  for (const char* f : {"000000.pcd", "000001.pcd"})
    fs::copy_file(test::shared_data("drives3d/hku-1/Scans/") + f, d + "/Scans/" + f);
  test::write_file(d, "odom_poses.txt", "1 0 0 0 0 1 0 0 0 0 1 0\n1 0 0 0 0 1 0 inf 0 0 1 0\n");
  const test::CliResult bad = test::run_cli("mapping " + test::quoted(d) + " -q");
  EXPECT_NE(bad.status, 0);
  EXPECT_NE(bad.out.find("odom_poses.txt: line 2: number 8: bad pose value: 'inf'"),
            std::string::npos)
      << bad.out;
}

TEST(DriveMappingCli, RepotWithADictionaryFileReportsItsTransfer) {
  if (!test::cli_built()) GTEST_SKIP() << "potmap command not built";
  const std::string d = test::temp_dir("drive-mapping-repot");
  write_dictionary(*test::drive_atoms("drives3d/hku-1", 3), d + "/atoms.potdict");
  const test::CliResult r = test::run_cli(
      "mapping " + test::quoted(test::shared_data("drives3d/hku-1")) + " --method repot --dict " +
          test::quoted(d + "/atoms.potdict") + " --first 10 --max-scans " +
          std::to_string(test::sized(4, 2)) + " -q -o " + test::quoted(d + "/out") + " --json -",
      "2>/dev/null");
  ASSERT_EQ(r.status, 0) << r.out;
  const nlohmann::json j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["method"], "RePOT");
  EXPECT_GT(j["transfer_ms_per_keyframe"].get<double>(), 0) << r.out;
  // RePOT's held-out scores are the BHM's where samples reach (measured on 4 keyframes from
  // 10: AUC 0.99, NLL 0.07).
  EXPECT_GT(j["scores"]["auc"].get<double>(), 0.97) << r.out;
  EXPECT_LT(j["scores"]["nll"].get<double>(), 0.15) << r.out;
}

TEST(DriveMappingCli, LookAheadScoresEveryKeyframeBeforeItIsLearned) {
  if (!test::cli_built()) GTEST_SKIP() << "potmap command not built";
  const std::string d = test::temp_dir("drive-mapping-lookahead");
  const test::CliResult r =
      test::run_cli("mapping " + test::quoted(test::shared_data("drives3d/hku-1")) +
                        " --max-scans 5 --lookahead -q -o " + test::quoted(d) + " --json -",
                    "2>/dev/null");
  ASSERT_EQ(r.status, 0) << r.out;
  const nlohmann::json j = nlohmann::json::parse(r.out);
  ASSERT_TRUE(j.contains("lookahead")) << r.out;
  const nlohmann::json& all = j["lookahead"]["all"];
  const nlohmann::json& beyond = j["lookahead"]["beyond_reach"];
  // Keyframes 1-4's kept held-out samples, each scored on the map of the keyframes before it.
  EXPECT_GT(all["n"].get<std::size_t>(), 1000u);
  EXPECT_LT(all["n"].get<std::size_t>(), j["scores"]["n"].get<std::size_t>());
  EXPECT_GT(all["auc"].get<double>(), 0.8) << all;
  EXPECT_LT(beyond["n"].get<std::size_t>(), all["n"].get<std::size_t>());
  EXPECT_EQ(scores_of(d), j);
  // A 2D log's POT has no persistent map to look ahead with: refused, not ignored.
  const test::CliResult log =
      test::run_cli("mapping " + test::quoted(test::shared_data("radish/intel-corrected.log.gz")) +
                        " --max-scans 2 --method pot --lookahead -q -o " + test::quoted(d + "-log"),
                    "2>&1");
  EXPECT_NE(log.status, 0);
  EXPECT_NE(log.out.find("--method pot has none"), std::string::npos) << log.out;
}
