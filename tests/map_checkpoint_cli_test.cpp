// `potmap map --checkpoint ... --resume` end to end on a real log: a run killed with SIGKILL at
// random moments and resumed each time ends with the same overall map file, byte for byte, as a
// run that was never stopped; a checkpoint of other input or options is refused naming what
// differs, and a truncated or corrupt one naming the file.
#include <gtest/gtest.h>
#include <signal.h>
#include <spawn.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <random>
#include <thread>

#include "test_support.hpp"

extern char** environ;
namespace fs = std::filesystem;
using potmap::test::quoted;

namespace {

// A small dictionary of the simulated town (as map_cli_test builds one), made once.
const std::string& dictionary() {
  static const std::string path = [] {
    const std::string d = potmap::test::temp_dir("map-checkpoint-dict");
    const std::string q = quoted(d);
    for (const std::string& args :
         {"data simulate --town town1 --seed 1 --scans 4 --spacing 3 --out " + q + "/src",
          "learn bhm " + q + "/src/train.csv -o " + q + "/src.potmap --gamma 4 --sequential",
          "dict build --scans " + q + "/src/scans.log --map " + q + "/src.potmap --out " + q +
              "/d.potdict"}) {
      const auto r = potmap::test::run_cli(args, "2>&1");
      EXPECT_EQ(r.status, 0) << args << "\n" << r.out;
    }
    return d + "/d.potdict";
  }();
  return path;
}

// RePOT by default (its persistent learner is most of a checkpoint); method "" maps POT.
std::string map_args(const std::string& out, const std::string& extra = "",
                     const std::string& method = "--refine") {
  return "map --dict " + quoted(dictionary()) + " --scans " +
         quoted(potmap::test::shared_data("radish/intel-corrected.log.gz")) +
         " --max-scans 40 --rotations 4 " + method + " -q -o " + quoted(out) + " " + extra;
}

// The inode of the file at `path`, 0 when there is none: a checkpoint replaced by rename() is a
// new inode.
ino_t inode_of(const std::string& path) {
  struct stat st;
  return ::stat(path.c_str(), &st) == 0 ? st.st_ino : 0;
}

pid_t spawn(const std::string& args, const std::string& log) {
  const std::string cmd = "exec " + quoted(POTMAP_CLI) + " " + args + " >" + quoted(log) + " 2>&1";
  const char* argv[] = {"/bin/sh", "-c", cmd.c_str(), nullptr};
  pid_t pid = 0;
  EXPECT_EQ(posix_spawn(&pid, "/bin/sh", nullptr, nullptr, const_cast<char**>(argv), environ), 0);
  return pid;
}

}  // namespace

TEST(MapCheckpointCli, KilledAtRandomAndResumedEndsWithTheSameMap) {
  if (!potmap::test::cli_built()) GTEST_SKIP() << "potmap command not built";
  const std::string dir = potmap::test::temp_dir("map-checkpoint-kill");
  const auto t0 = std::chrono::steady_clock::now();
  const auto whole = potmap::test::run_cli(
      map_args(dir + "/whole.potmap", "--checkpoint-every 0 --json " + quoted(dir + "/whole.json")),
      "2>&1");
  const auto whole_ms =
      std::chrono::duration_cast<std::chrono::milliseconds>(std::chrono::steady_clock::now() - t0)
          .count();
  ASSERT_EQ(whole.status, 0) << whole.out;
  EXPECT_FALSE(fs::exists(dir + "/whole.potmap.ckpt"));

  const std::string out = dir + "/killed.potmap", ckpt = dir + "/run.ckpt";
  const std::string args =
      map_args(out, "--checkpoint " + quoted(ckpt) + " --checkpoint-every 3 --resume --json " +
                        quoted(dir + "/killed.json"));
  std::mt19937 rng(20261201);
  // Kills land within the first quarter of a whole run's time after a checkpoint, so that on a
  // machine of any speed most runs are killed mid-way rather than finishing first.
  std::uniform_int_distribution<int> delay_ms(0, std::max(1, int(whole_ms / 4)));
  int kills = 0;
  for (int attempt = 0; attempt < 5 && kills < 3; ++attempt) {
    const ino_t before = inode_of(ckpt);
    const std::string log = dir + "/run" + std::to_string(attempt) + ".log";
    const pid_t pid = spawn(args, log);
    // Wait for a checkpoint this run wrote, then kill it a random moment later.
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(120);
    int status = 0;
    bool exited = false;
    while (inode_of(ckpt) == before || inode_of(ckpt) == 0) {
      if (waitpid(pid, &status, WNOHANG) == pid) {
        exited = true;
        break;
      }
      ASSERT_LT(std::chrono::steady_clock::now(), deadline) << "no checkpoint appeared";
      std::this_thread::sleep_for(std::chrono::milliseconds(2));
    }
    if (exited) break;  // it finished before writing another checkpoint
    std::this_thread::sleep_for(std::chrono::milliseconds(delay_ms(rng)));
    if (waitpid(pid, &status, WNOHANG) == pid) break;  // finished meanwhile
    ASSERT_EQ(kill(pid, SIGKILL), 0);
    ASSERT_EQ(waitpid(pid, &status, 0), pid);
    ASSERT_TRUE(WIFSIGNALED(status));
    ++kills;
    EXPECT_FALSE(fs::exists(out)) << "the map is written only at the end";
    ASSERT_TRUE(fs::exists(ckpt));
    if (attempt > 0) {
      const std::string said = potmap::test::file_bytes(log);
      EXPECT_NE(said.find("potmap map: resumed from " + ckpt + " at scan "), std::string::npos)
          << said;
    }
  }
  EXPECT_GE(kills, 2) << "the runs finished before they could be killed";
  const auto last = potmap::test::run_cli(args, "2>&1");
  ASSERT_EQ(last.status, 0) << last.out;
  EXPECT_NE(last.out.find("resumed from"), std::string::npos) << last.out;
  ASSERT_TRUE(fs::exists(out));
  EXPECT_EQ(potmap::test::file_bytes(out), potmap::test::file_bytes(dir + "/whole.potmap"));
  EXPECT_FALSE(fs::exists(ckpt)) << "removed after a successful finish";
  for (const auto& e : fs::directory_iterator(dir))  // nor what a kill mid-write left
    EXPECT_EQ(e.path().filename().string().find("run.ckpt.tmp-"), std::string::npos) << e.path();
  // The summary covers every scan, scored as the uninterrupted run's.
  const std::string a = potmap::test::file_bytes(dir + "/whole.json"),
                    b = potmap::test::file_bytes(dir + "/killed.json");
  for (const char* key : {"\"scans\": 40", "\"overall_kernels\""}) {
    EXPECT_NE(a.find(key), std::string::npos) << key;
    EXPECT_NE(b.find(key), std::string::npos) << key;
  }
  auto section = [](const std::string& j, const std::string& key) {
    const std::size_t at = j.find("\"" + key + "\"");
    return at == std::string::npos ? std::string() : j.substr(at, j.find('}', at) - at);
  };
  for (const char* key : {"overall", "instantaneous"}) {
    EXPECT_FALSE(section(a, key).empty()) << key;
    EXPECT_EQ(section(a, key), section(b, key)) << key;
  }
}

TEST(MapCheckpointCli, RefusesOtherRunsAndBrokenCheckpoints) {
  if (!potmap::test::cli_built()) GTEST_SKIP() << "potmap command not built";
  const std::string dir = potmap::test::temp_dir("map-checkpoint-refusals");
  const std::string ckpt = dir + "/kept.ckpt";
  // POT (the kill test maps RePOT), 8 scans, a checkpoint after 5 kept at the end.
  const std::string base = "--max-scans 8 --checkpoint " + quoted(ckpt);
  auto args = [&](const std::string& extra) {
    std::string a = map_args(dir + "/m.potmap", base + " " + extra, "");
    return a.replace(a.find("--max-scans 40 "), 15, "");
  };
  auto r = potmap::test::run_cli(args("--checkpoint-every 5 --keep-checkpoint"), "2>&1");
  ASSERT_EQ(r.status, 0) << r.out;
  ASSERT_TRUE(fs::exists(ckpt)) << r.out;
  const std::string good = potmap::test::file_bytes(ckpt);

  // Other options, another input: refused, naming the checkpoint and what differs.
  r = potmap::test::run_cli(args("--resume --seed 3"), "2>&1");
  EXPECT_NE(r.status, 0);
  EXPECT_NE(r.out.find(ckpt), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("--seed: the checkpoint has 0, this run 3"), std::string::npos) << r.out;
  r = potmap::test::run_cli(args("--resume --first 2"), "2>&1");
  EXPECT_NE(r.status, 0);
  EXPECT_NE(r.out.find("--first"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("scans fingerprint"), std::string::npos) << r.out;

  // Truncated and corrupt checkpoints: an error naming the file, no crash.
  std::ofstream(ckpt, std::ios::binary) << good.substr(0, good.size() / 3);
  r = potmap::test::run_cli(args("--resume"), "2>&1");
  EXPECT_EQ(r.status, 1) << r.out;
  EXPECT_NE(r.out.find(ckpt), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("truncated"), std::string::npos) << r.out;
  std::string flipped = good;
  flipped[flipped.size() / 2] ^= 0x04;
  std::ofstream(ckpt, std::ios::binary) << flipped;
  r = potmap::test::run_cli(args("--resume"), "2>&1");
  EXPECT_EQ(r.status, 1) << r.out;
  EXPECT_NE(r.out.find(ckpt), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("checksum"), std::string::npos) << r.out;
  EXPECT_FALSE(fs::exists(dir + "/m.potmap.ckpt"));

  // By time: a checkpoint after the first scan already.
  fs::remove(ckpt);
  r = potmap::test::run_cli(
      args("--checkpoint-every 0 --checkpoint-seconds 0.000001 --keep-checkpoint --json -"),
      "2>/dev/null");
  ASSERT_EQ(r.status, 0) << r.out;
  EXPECT_NE(r.out.find("\"written\": 7"), std::string::npos) << r.out;  // after scans 1 to 7
  EXPECT_TRUE(fs::exists(ckpt));

  // The good one resumes at scan 6 and ends as a run from the start.
  std::ofstream(ckpt, std::ios::binary) << good;
  const std::string first = potmap::test::file_bytes(dir + "/m.potmap");
  fs::remove(dir + "/m.potmap");
  r = potmap::test::run_cli(args("--resume"), "2>&1");
  ASSERT_EQ(r.status, 0) << r.out;
  EXPECT_NE(r.out.find("resumed from " + ckpt + " at scan 6/8"), std::string::npos) << r.out;
  EXPECT_EQ(potmap::test::file_bytes(dir + "/m.potmap"), first);
  EXPECT_FALSE(fs::exists(ckpt));
}
