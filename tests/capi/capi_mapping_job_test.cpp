// C API: the mapping job, a real drive mapped into a folder in one call, checked against the
// potmap command on the same keyframes (the same files and scores), stopped by its progress
// callback, and refused with its option named.
#include <nlohmann/json.hpp>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "capi_test_support.hpp"

using namespace capi_test;
namespace fs = std::filesystem;

namespace {

struct Seen {
  std::vector<std::string> stages, notes;
  std::vector<std::size_t> keyframes;
  std::size_t stop_at = 0;  // 0: never stop
};

int on_progress(const potmap_job_progress* p, void* user) {
  auto* seen = static_cast<Seen*>(user);
  seen->stages.push_back(p->stage);
  if (std::string(p->unit) == "keyframe") seen->keyframes.push_back(p->done);
  return seen->stop_at && std::string(p->unit) == "keyframe" && p->done == seen->stop_at;
}

void on_note(const char* line, void* user) {
  static_cast<Seen*>(user)->notes.push_back(line);
}

nlohmann::json read_json(const std::string& path) {
  std::ifstream f(path);
  return nlohmann::json::parse(f);
}

std::vector<std::string> names(const nlohmann::json& files) {
  std::vector<std::string> out;
  for (const auto& f : files) out.push_back(fs::path(f.get<std::string>()).filename().string());
  return out;
}

}  // namespace

TEST(CApiMappingJob, OptionsInitToTheCommandsDefaults) {
  potmap_mapping_job_options o;
  POTMAP_ASSERT_OK(potmap_mapping_job_options_init(&o, sizeof o));
  EXPECT_EQ(o.struct_size, sizeof o);
  EXPECT_EQ(o.out, nullptr);
  EXPECT_EQ(o.method, nullptr);
  EXPECT_EQ(o.range_cut, -1.0);
  EXPECT_EQ(o.picture_pixels, 1200u);
  EXPECT_EQ(o.band_low, -1.0);
  EXPECT_EQ(o.band_high, 0.5);
  EXPECT_EQ(o.voxel, 0.4);
  EXPECT_EQ(o.checkpoint_seconds, 30.0);
  EXPECT_EQ(o.resume, 0);
}

TEST(CApiMappingJob, MapsADriveIntoTheCommandsFilesAndScores) {
  const std::string dir = temp_dir("mapping-job");
  const std::string drive = shared_data("drives3d/hku-1");
  potmap_mapping_job_options o;
  POTMAP_ASSERT_OK(potmap_mapping_job_options_init(&o, sizeof o));
  const std::string out = dir + "/c";
  o.out = out.c_str();
  o.max_scans = 3;
  Seen seen;
  potmap_mapping_job_result r;
  r.struct_size = sizeof r;
  POTMAP_ASSERT_OK(
      potmap_map_recording(shared_context(), drive.c_str(), &o, on_note, on_progress, &seen, &r));
  EXPECT_EQ(r.drive, 1);
  EXPECT_EQ(seen.keyframes, (std::vector<std::size_t>{1, 2, 3}));
  EXPECT_EQ(seen.stages.back(), "outputs");
  ASSERT_FALSE(seen.notes.empty());
  EXPECT_TRUE(contains(seen.notes.front(), "keyframes 0-2")) << seen.notes.front();

  const std::string cmd = std::string(POTMAP_BINARY_DIR) + "/tools/potmap mapping " + drive +
                          " --max-scans 3 -q -o " + dir + "/cmd > " + dir + "/cmd.log 2>&1";
  ASSERT_EQ(std::system(cmd.c_str()), 0) << cmd;
  const nlohmann::json mine = read_json(out + "/scores.json");
  const nlohmann::json theirs = read_json(dir + "/cmd/scores.json");
  EXPECT_EQ(mine["scores"], theirs["scores"]);
  EXPECT_EQ(mine["kernels"], theirs["kernels"]);
  EXPECT_EQ(names(mine["files"]), names(theirs["files"]));
  EXPECT_EQ(r.files, mine["files"].size());
  EXPECT_EQ(r.auc, mine["scores"]["auc"].get<double>());
  EXPECT_EQ(r.samples, mine["scores"]["n"].get<std::size_t>());
  for (const auto& f : mine["files"]) EXPECT_TRUE(fs::exists(f.get<std::string>())) << f;
}

// A 2D log's look-ahead (RePOT's persistent map before each scan) reaches the C result as
// scores.json has it.
TEST(CApiMappingJob, ALogsLookAheadReachesTheResult) {
  const std::string out = temp_dir("mapping-job-log-ahead") + "/c";
  potmap_mapping_job_options o;
  POTMAP_ASSERT_OK(potmap_mapping_job_options_init(&o, sizeof o));
  o.out = out.c_str();
  o.max_scans = 6;
  o.lookahead = 1;
  potmap_mapping_job_result r;
  r.struct_size = sizeof r;
  POTMAP_ASSERT_OK(potmap_map_recording(shared_context(),
                                        shared_data("radish/intel-corrected.log.gz").c_str(), &o,
                                        nullptr, nullptr, nullptr, &r));
  EXPECT_EQ(r.drive, 0);
  const nlohmann::json j = read_json(out + "/scores.json");
  ASSERT_TRUE(j.contains("lookahead")) << j;
  EXPECT_EQ(r.lookahead_samples, j["lookahead"]["all"]["n"].get<std::size_t>());
  EXPECT_EQ(r.lookahead_nll, j["lookahead"]["all"]["nll"].get<double>());
  EXPECT_EQ(r.beyond_samples, j["lookahead"]["beyond_reach"]["n"].get<std::size_t>());
  EXPECT_GT(r.lookahead_samples, 0u);
  EXPECT_LT(r.lookahead_samples, r.samples);  // the first scan's are not scored
}

TEST(CApiMappingJob, StoppedByItsProgressLeavesOnlyWholeFiles) {
  const std::string out = temp_dir("mapping-job-stop") + "/c";
  potmap_mapping_job_options o;
  POTMAP_ASSERT_OK(potmap_mapping_job_options_init(&o, sizeof o));
  o.out = out.c_str();
  o.max_scans = 5;
  Seen seen;
  seen.stop_at = 2;
  POTMAP_EXPECT_FAIL(potmap_map_recording(shared_context(), shared_data("drives3d/hku-1").c_str(),
                                          &o, nullptr, on_progress, &seen, nullptr),
                     POTMAP_ERROR_CANCELLED);
  EXPECT_EQ(seen.keyframes, (std::vector<std::size_t>{1, 2}));
  EXPECT_FALSE(fs::exists(out + "/scores.json"));
  for (const auto& e : fs::directory_iterator(out))
    EXPECT_EQ(e.path().filename().string().find(".tmp"), std::string::npos) << e.path();
}

TEST(CApiMappingJob, BadOptionsAreRefusedNamingTheField) {
  const std::string drive = shared_data("drives3d/hku-1");
  potmap_mapping_job_options o;
  POTMAP_ASSERT_OK(potmap_mapping_job_options_init(&o, sizeof o));
  POTMAP_EXPECT_FAIL(
      potmap_map_recording(shared_context(), drive.c_str(), &o, nullptr, nullptr, nullptr, nullptr),
      POTMAP_ERROR_INVALID_ARGUMENT);
  EXPECT_TRUE(contains(potmap_last_error(), "options->out")) << potmap_last_error();
  const std::string out = temp_dir("mapping-job-bad") + "/c";
  o.out = out.c_str();
  o.voxel = 0;
  POTMAP_EXPECT_FAIL(
      potmap_map_recording(shared_context(), drive.c_str(), &o, nullptr, nullptr, nullptr, nullptr),
      POTMAP_ERROR_INVALID_ARGUMENT);
  EXPECT_TRUE(contains(potmap_last_error(), "voxel")) << potmap_last_error();
  o.voxel = 0.4;
  o.method = "pot";  // POT's averaged map of a whole drive grows with it: refused for drives
  POTMAP_EXPECT_FAIL(
      potmap_map_recording(shared_context(), drive.c_str(), &o, nullptr, nullptr, nullptr, nullptr),
      POTMAP_ERROR_INVALID_ARGUMENT);
  EXPECT_TRUE(contains(potmap_last_error(), "pot")) << potmap_last_error();
  o.method = nullptr;
  POTMAP_EXPECT_FAIL(potmap_map_recording(shared_context(), shared_data("no-such").c_str(), &o,
                                          nullptr, nullptr, nullptr, nullptr),
                     POTMAP_ERROR_INPUT);
}
