// C API: a real drive read as a dataset, mapped keyframe by keyframe by the drive mapper, scored
// on its held-out samples; options, stats and states checked as every C API struct is.
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <fstream>
#include <string>
#include <vector>

#include "capi_test_support.hpp"

using namespace capi_test;

namespace {

// AUC of probabilities against labels (ties split), for the check below.
double auc(const std::vector<float>& p, const uint8_t* y, std::size_t n) {
  double pos = 0, neg = 0, wins = 0;
  for (std::size_t i = 0; i < n; ++i) (y[i] ? pos : neg) += 1;
  for (std::size_t i = 0; i < n; i += 7)
    for (std::size_t j = 0; j < n; j += 7)
      if (y[i] && !y[j]) wins += p[i] > p[j] ? 1.0 : p[i] == p[j] ? 0.5 : 0.0;
  double a = 0, b = 0;
  for (std::size_t i = 0; i < n; i += 7) (y[i] ? a : b) += 1;
  return pos > 0 && neg > 0 ? wins / (a * b) : NAN;
}

}  // namespace

TEST(CApiDriveMapper, OptionsInitToTheDriveDefaults) {
  potmap_drive_mapper_options o;
  POTMAP_ASSERT_OK(potmap_drive_mapper_options_init(&o, sizeof o));
  EXPECT_EQ(o.struct_size, sizeof o);
  EXPECT_EQ(o.range_cut, 40.0);
  EXPECT_EQ(o.free_per_metre, 0.5);
  EXPECT_EQ(o.holdout_fraction, 0.2);
  EXPECT_EQ(o.voxel, 0.5);
  EXPECT_EQ(o.retire_radius, -1.0);
  EXPECT_EQ(o.sums, POTMAP_SUMS_AUTOMATIC);
  EXPECT_EQ(o.half_life, 0.0);
  EXPECT_EQ(o.lookahead, 0);
  potmap_drive_mapper* m = nullptr;
  o.half_life = -2;
  POTMAP_EXPECT_FAIL(potmap_drive_mapper_create(nullptr, &o, &m), POTMAP_ERROR_INVALID_ARGUMENT);
  EXPECT_TRUE(contains(potmap_last_error(), "half_life")) << potmap_last_error();
  o.half_life = 0;
  o.sums = 3;
  POTMAP_EXPECT_FAIL(potmap_drive_mapper_create(nullptr, &o, &m), POTMAP_ERROR_INVALID_ARGUMENT);
  EXPECT_TRUE(contains(potmap_last_error(), "sums")) << potmap_last_error();
  o.sums = POTMAP_SUMS_AUTOMATIC;
  o.range_cut = -1;
  POTMAP_EXPECT_FAIL(potmap_drive_mapper_create(nullptr, &o, &m), POTMAP_ERROR_INVALID_ARGUMENT);
  EXPECT_TRUE(contains(potmap_last_error(), "range_cut")) << potmap_last_error();
  EXPECT_EQ(m, nullptr);
  POTMAP_EXPECT_FAIL(potmap_drive_mapper_options_init(&o, 4), POTMAP_ERROR_INVALID_ARGUMENT);
}

TEST(CApiDriveMapper, MapsADriveReadAsADataset) {
  potmap_dataset* data = nullptr;
  POTMAP_ASSERT_OK(potmap_dataset_load(shared_data("drives3d/hku-1").c_str(), &data));
  size_t n = 0;
  POTMAP_ASSERT_OK(potmap_dataset_size(data, &n));
  ASSERT_EQ(n, 314u);
  potmap_drive_mapper* m = nullptr;
  potmap_drive_mapper_options mo;
  POTMAP_ASSERT_OK(potmap_drive_mapper_options_init(&mo, sizeof mo));
  mo.lookahead = 1;
  POTMAP_ASSERT_OK(potmap_drive_mapper_create(shared_context(), &mo, &m));
  potmap_scan s;
  POTMAP_ASSERT_OK(potmap_scan_init(&s, sizeof s));
  potmap_keyframe_stats st;
  st.struct_size = sizeof st;
  for (size_t i = 0; i < 6; ++i) {
    POTMAP_ASSERT_OK(potmap_dataset_scan(data, i, &s));
    POTMAP_ASSERT_OK(potmap_drive_mapper_add_keyframe(m, &s, int64_t(i), &st));
    EXPECT_GT(st.samples, st.gathered);
    EXPECT_GT(st.held_out, 0u);
    EXPECT_GT(st.memory_bytes, 0u);
    // The look-ahead's time: from the second keyframe on (the first has no map before it).
    if (i == 0)
      EXPECT_EQ(st.lookahead_ms, 0.0);
    else
      EXPECT_GT(st.lookahead_ms, 0.0) << i;
  }
  // Keyframes 1-5 scored before each was learned: the walk sees mostly what it saw before.
  double la_auc = 0, la_nll = 0, b_auc = 0, b_nll = 0;
  size_t la_n = 0, b_n = 0;
  POTMAP_ASSERT_OK(potmap_drive_mapper_lookahead(m, &la_auc, &la_nll, &la_n, &b_auc, &b_nll, &b_n));
  EXPECT_GT(la_n, 1000u);
  EXPECT_GT(la_auc, 0.8);
  EXPECT_LT(b_n, la_n);
  POTMAP_ASSERT_OK(
      potmap_drive_mapper_lookahead(m, nullptr, nullptr, nullptr, nullptr, nullptr, nullptr));
  POTMAP_EXPECT_FAIL(
      potmap_drive_mapper_lookahead(nullptr, &la_auc, nullptr, nullptr, nullptr, nullptr, nullptr),
      POTMAP_ERROR_NULL_ARGUMENT);
  // A state saved and loaded into another mapper gives the same map.
  const std::string path = temp_dir("capi-drive") + "/m.state";
  POTMAP_ASSERT_OK(potmap_drive_mapper_save_state(m, path.c_str()));
  potmap_drive_mapper* m2 = nullptr;
  POTMAP_ASSERT_OK(potmap_drive_mapper_create(nullptr, nullptr, &m2));
  POTMAP_ASSERT_OK(potmap_drive_mapper_load_state(m2, path.c_str()));
  potmap_map *map = nullptr, *map2 = nullptr;
  POTMAP_ASSERT_OK(potmap_drive_mapper_map(m, &map));
  POTMAP_ASSERT_OK(potmap_drive_mapper_map(m2, &map2));
  size_t k = 0, k2 = 0;
  int dim = 0;
  POTMAP_ASSERT_OK(potmap_map_size(map, &dim, &k));
  EXPECT_EQ(dim, 3);
  POTMAP_ASSERT_OK(potmap_map_size(map2, &dim, &k2));
  EXPECT_GT(k, 1000u);
  EXPECT_EQ(k, k2);
  // The held-out samples, scored on the map: the Livox walk's continuous map (AUC 0.98 on 4
  // keyframes through `potmap mapping`).
  size_t nt = 0;
  const double* pts = nullptr;
  const uint8_t* labels = nullptr;
  POTMAP_ASSERT_OK(potmap_drive_mapper_held_out(m, &nt, &pts, &labels));
  ASSERT_GT(nt, 1000u);
  potmap_evaluator* ev = nullptr;
  POTMAP_ASSERT_OK(potmap_evaluator_create(shared_context(), map, 0, &ev));
  std::vector<float> prob(nt);
  POTMAP_ASSERT_OK(potmap_evaluate(ev, pts, nt, 3, nullptr, nullptr, prob.data(), nt));
  EXPECT_GT(auc(prob, labels, nt), 0.95);
  // A 2D scan and a short stats struct are refused, the mapper unchanged.
  potmap_scan flat;
  POTMAP_ASSERT_OK(potmap_scan_init(&flat, sizeof flat));
  const double hit[2] = {1, 2};
  flat.hits = hit;
  flat.num_hits = 1;
  flat.max_range = 10;
  POTMAP_EXPECT_FAIL(potmap_drive_mapper_add_keyframe(m, &flat, 9, nullptr),
                     POTMAP_ERROR_DIMENSION_MISMATCH);
  st.struct_size = 4;
  POTMAP_ASSERT_OK(potmap_dataset_scan(data, 6, &s));
  POTMAP_EXPECT_FAIL(potmap_drive_mapper_add_keyframe(m, &s, 6, &st),
                     POTMAP_ERROR_BUFFER_TOO_SMALL);
  POTMAP_EXPECT_FAIL(potmap_drive_mapper_load_state(m, (path + ".none").c_str()),
                     POTMAP_ERROR_INPUT);
  POTMAP_ASSERT_OK(potmap_evaluator_destroy(ev));
  POTMAP_ASSERT_OK(potmap_map_destroy(map));
  POTMAP_ASSERT_OK(potmap_map_destroy(map2));
  POTMAP_ASSERT_OK(potmap_drive_mapper_destroy(m));
  POTMAP_ASSERT_OK(potmap_drive_mapper_destroy(m2));
  POTMAP_ASSERT_OK(potmap_drive_mapper_destroy(nullptr));
  POTMAP_ASSERT_OK(potmap_dataset_destroy(data));
}

TEST(CApiDriveMapper, TheMapSoFarExportsAnOctomapAndACloud) {
  potmap_dataset* data = nullptr;
  POTMAP_ASSERT_OK(potmap_dataset_load(shared_data("drives3d/hku-1").c_str(), &data));
  potmap_drive_mapper* m = nullptr;
  POTMAP_ASSERT_OK(potmap_drive_mapper_create(shared_context(), nullptr, &m));
  potmap_scan s;
  POTMAP_ASSERT_OK(potmap_scan_init(&s, sizeof s));
  std::vector<double> path;
  for (size_t i = 0; i < 4; ++i) {
    POTMAP_ASSERT_OK(potmap_dataset_scan(data, i, &s));
    POTMAP_ASSERT_OK(potmap_drive_mapper_add_keyframe(m, &s, int64_t(i), nullptr));
    path.insert(path.end(), {s.pose[3], s.pose[7], s.pose[11]});
  }
  potmap_map* map = nullptr;
  POTMAP_ASSERT_OK(potmap_drive_mapper_map(m, &map));
  const std::string dir = temp_dir("capi-drive-volume");
  const std::string bt = dir + "/so_far.bt", ply = dir + "/so_far.ply";
  potmap_drive_volume_options o;
  POTMAP_ASSERT_OK(potmap_drive_volume_options_init(&o, sizeof o));
  EXPECT_EQ(o.voxel, 0.4);
  EXPECT_EQ(o.band_low, -1.0);
  o.octomap_path = bt.c_str();
  o.cloud_path = ply.c_str();
  potmap_drive_volume_summary v;
  v.struct_size = sizeof v;
  POTMAP_ASSERT_OK(potmap_export_drive_volume(shared_context(), map, path.data(), 4, &o, &v));
  EXPECT_GT(v.blocks, 10u);
  EXPECT_GT(v.occupied_voxels, 1000u);
  EXPECT_GT(v.free_voxels, v.occupied_voxels);
  EXPECT_EQ(v.occupied_voxels + v.free_voxels + v.unknown_voxels, v.blocks * 4096);
  EXPECT_GT(v.octomap_leaves, 1000u);
  auto first_line = [](const std::string& file) {
    std::ifstream f(file, std::ios::binary);
    std::string line;
    std::getline(f, line);
    return line;
  };
  EXPECT_EQ(first_line(bt), "# Octomap OcTree binary file");
  EXPECT_EQ(first_line(ply), "ply");
  // Refusals name the field; a bad call writes nothing.
  o.voxel = 0;
  o.octomap_path = (dir + "/bad.bt").c_str();
  POTMAP_EXPECT_FAIL(potmap_export_drive_volume(shared_context(), map, path.data(), 4, &o, &v),
                     POTMAP_ERROR_INVALID_ARGUMENT);
  EXPECT_TRUE(contains(potmap_last_error(), "voxel")) << potmap_last_error();
  EXPECT_FALSE(std::ifstream(dir + "/bad.bt").good());
  POTMAP_ASSERT_OK(potmap_drive_volume_options_init(&o, sizeof o));
  POTMAP_EXPECT_FAIL(potmap_export_drive_volume(shared_context(), map, path.data(), 0, &o, &v),
                     POTMAP_ERROR_INVALID_ARGUMENT);
  potmap_map* flat = nullptr;
  POTMAP_ASSERT_OK(potmap_map_create(2, 0, nullptr, nullptr, nullptr, nullptr, &flat));
  POTMAP_EXPECT_FAIL(potmap_export_drive_volume(shared_context(), flat, path.data(), 4, &o, &v),
                     POTMAP_ERROR_DIMENSION_MISMATCH);
  POTMAP_ASSERT_OK(potmap_map_destroy(flat));
  POTMAP_ASSERT_OK(potmap_map_destroy(map));
  POTMAP_ASSERT_OK(potmap_drive_mapper_destroy(m));
  POTMAP_ASSERT_OK(potmap_dataset_destroy(data));
}

TEST(CApiDriveMapper, RepotSeedsFromADictionaryOfTheDrive) {
  potmap_dataset* data = nullptr;
  POTMAP_ASSERT_OK(potmap_dataset_load(shared_data("drives3d/hku-1").c_str(), &data));
  potmap_drive_mapper_options mo;
  POTMAP_ASSERT_OK(potmap_drive_mapper_options_init(&mo, sizeof mo));
  mo.range_cut = 20;
  mo.transfer_every = 1;
  // The atoms: keyframes 0-2 mapped by the joint BHM, cut into 20 m sectors.
  potmap_drive_mapper* src = nullptr;
  POTMAP_ASSERT_OK(potmap_drive_mapper_create(shared_context(), &mo, &src));
  std::vector<potmap_scan> scans(3);
  std::vector<const potmap_scan*> ptrs;
  for (size_t i = 0; i < scans.size(); ++i) {
    POTMAP_ASSERT_OK(potmap_scan_init(&scans[i], sizeof scans[i]));
    POTMAP_ASSERT_OK(potmap_dataset_scan(data, i, &scans[i]));
    POTMAP_ASSERT_OK(potmap_drive_mapper_add_keyframe(src, &scans[i], int64_t(i), nullptr));
    ptrs.push_back(&scans[i]);
  }
  potmap_map* map = nullptr;
  POTMAP_ASSERT_OK(potmap_drive_mapper_map(src, &map));
  potmap_dictionary_options dopt;
  POTMAP_ASSERT_OK(potmap_dictionary_options_init(&dopt, sizeof dopt));
  dopt.max_range = 20;
  dopt.max_weight_variance = 5;
  potmap_dictionary* dict = nullptr;
  POTMAP_ASSERT_OK(potmap_dictionary_build(ptrs.data(), ptrs.size(), map, &dopt, &dict));
  potmap_drive_mapper* m = nullptr;
  POTMAP_EXPECT_FAIL(potmap_drive_mapper_create_repot(shared_context(), &mo, nullptr, &m),
                     POTMAP_ERROR_NULL_ARGUMENT);
  POTMAP_ASSERT_OK(potmap_drive_mapper_create_repot(shared_context(), &mo, dict, &m));
  POTMAP_ASSERT_OK(potmap_dictionary_destroy(dict));  // the mapper shares the atoms
  potmap_keyframe_stats st;
  st.struct_size = sizeof st;
  size_t seeded = 0;
  potmap_scan s;
  POTMAP_ASSERT_OK(potmap_scan_init(&s, sizeof s));
  for (size_t i = 10; i < 12; ++i) {
    POTMAP_ASSERT_OK(potmap_dataset_scan(data, i, &s));
    POTMAP_ASSERT_OK(potmap_drive_mapper_add_keyframe(m, &s, int64_t(i), &st));
    EXPECT_GT(st.transfer_ms, 0);
    seeded += st.seeded;
  }
  EXPECT_GT(seeded, 0u);
  // A caller built against the first potmap_keyframe_stats (no transfer fields) still works.
  st.struct_size = offsetof(potmap_keyframe_stats, transfer_ms);
  POTMAP_ASSERT_OK(potmap_dataset_scan(data, 12, &s));
  POTMAP_ASSERT_OK(potmap_drive_mapper_add_keyframe(m, &s, 12, &st));
  POTMAP_ASSERT_OK(potmap_map_destroy(map));
  POTMAP_ASSERT_OK(potmap_drive_mapper_destroy(m));
  POTMAP_ASSERT_OK(potmap_drive_mapper_destroy(src));
  POTMAP_ASSERT_OK(potmap_dataset_destroy(data));
}

// Where the joint BHM's sums run is the caller's choice, and the stats say where they ran: on
// the device and on the host, the same keyframes give the same held-out samples and map size.
TEST(CApiDriveMapper, SumsRunWhereTheOptionsSay) {
  potmap_dataset* data = nullptr;
  POTMAP_ASSERT_OK(potmap_dataset_load(shared_data("drives3d/hku-1").c_str(), &data));
  potmap_scan s;
  POTMAP_ASSERT_OK(potmap_scan_init(&s, sizeof s));
  size_t kernels[2] = {0, 0};
  for (int device = 0; device < 2; ++device) {
    potmap_drive_mapper_options o;
    POTMAP_ASSERT_OK(potmap_drive_mapper_options_init(&o, sizeof o));
    o.sums = device ? POTMAP_SUMS_DEVICE : POTMAP_SUMS_HOST;
    potmap_drive_mapper* m = nullptr;
    POTMAP_ASSERT_OK(potmap_drive_mapper_create(shared_context(), &o, &m));
    potmap_keyframe_stats st;
    st.struct_size = sizeof st;
    for (size_t i = 0; i < 2; ++i) {
      POTMAP_ASSERT_OK(potmap_dataset_scan(data, i, &s));
      POTMAP_ASSERT_OK(potmap_drive_mapper_add_keyframe(m, &s, int64_t(i), &st));
      EXPECT_EQ(st.sums_on_device, device);  // the PoCL device has doubles
    }
    potmap_map* map = nullptr;
    POTMAP_ASSERT_OK(potmap_drive_mapper_map(m, &map));
    int dim = 0;
    POTMAP_ASSERT_OK(potmap_map_size(map, &dim, &kernels[device]));
    POTMAP_ASSERT_OK(potmap_map_destroy(map));
    POTMAP_ASSERT_OK(potmap_drive_mapper_destroy(m));
  }
  EXPECT_GT(kernels[0], 1000u);
  EXPECT_EQ(kernels[0], kernels[1]);
  POTMAP_ASSERT_OK(potmap_dataset_destroy(data));
}

// Two drive mappers of the two halves of a few keyframes, saved with their information form
// and merged from C; the map merged with itself, and a map without the form, refused.
TEST(CApiDriveMapper, HalvesSavedAndMerged) {
  potmap_dataset* data = nullptr;
  POTMAP_ASSERT_OK(potmap_dataset_load(shared_data("drives3d/hku-1").c_str(), &data));
  potmap_drive_mapper_options o;
  POTMAP_ASSERT_OK(potmap_drive_mapper_options_init(&o, sizeof o));
  o.range_cut = 20;
  o.retire_radius = 0;  // every tile kept: the information form is whole
  potmap_drive_mapper *a = nullptr, *b = nullptr;
  POTMAP_ASSERT_OK(potmap_drive_mapper_create(shared_context(), &o, &a));
  POTMAP_ASSERT_OK(potmap_drive_mapper_create(shared_context(), &o, &b));
  potmap_scan s;
  POTMAP_ASSERT_OK(potmap_scan_init(&s, sizeof s));
  for (size_t i = 0; i < 4; ++i) {
    POTMAP_ASSERT_OK(potmap_dataset_scan(data, i, &s));
    POTMAP_ASSERT_OK(potmap_drive_mapper_add_keyframe(i < 2 ? a : b, &s, int64_t(i), nullptr));
  }
  const std::string dir = temp_dir("capi-merge");
  const std::string pa = dir + "/a.potmap", pb = dir + "/b.potmap", pc = dir + "/c.potmap";
  const std::string plain = dir + "/plain.potmap";
  POTMAP_ASSERT_OK(potmap_drive_mapper_save_map(a, pa.c_str()));
  POTMAP_ASSERT_OK(potmap_drive_mapper_save_map(b, pb.c_str()));
  potmap_map* am = nullptr;
  POTMAP_ASSERT_OK(potmap_drive_mapper_map(a, &am));
  POTMAP_ASSERT_OK(potmap_map_save(am, plain.c_str()));
  const char* ab[] = {pa.c_str(), pb.c_str()};
  POTMAP_ASSERT_OK(potmap_merge_maps(ab, 2, pc.c_str(), 0));
  potmap_map *c = nullptr, *bm = nullptr;
  POTMAP_ASSERT_OK(potmap_map_load(pc.c_str(), &c));
  POTMAP_ASSERT_OK(potmap_drive_mapper_map(b, &bm));
  int dim = 0;
  size_t kc = 0, ka = 0, kb = 0;
  POTMAP_ASSERT_OK(potmap_map_size(c, &dim, &kc));
  POTMAP_ASSERT_OK(potmap_map_size(am, &dim, &ka));
  POTMAP_ASSERT_OK(potmap_map_size(bm, &dim, &kb));
  EXPECT_GE(kc, std::max(ka, kb));  // the union of the halves' tiles
  EXPECT_LE(kc, ka + kb);
  const char* aa[] = {pa.c_str(), pa.c_str()};
  POTMAP_EXPECT_FAIL(potmap_merge_maps(aa, 2, pc.c_str(), 0), POTMAP_ERROR_INVALID_ARGUMENT);
  EXPECT_TRUE(contains(potmap_last_error(), "scan fingerprints")) << potmap_last_error();
  POTMAP_ASSERT_OK(potmap_merge_maps(aa, 2, (dir + "/aa.potmap").c_str(), 1));
  const char* ap[] = {pa.c_str(), plain.c_str()};
  POTMAP_EXPECT_FAIL(potmap_merge_maps(ap, 2, pc.c_str(), 0), POTMAP_ERROR_INPUT);
  EXPECT_TRUE(contains(potmap_last_error(), "plain.potmap: written without its information form"))
      << potmap_last_error();
  POTMAP_EXPECT_FAIL(potmap_merge_maps(ab, 1, pc.c_str(), 0), POTMAP_ERROR_INVALID_ARGUMENT);
  POTMAP_EXPECT_FAIL(potmap_merge_maps(nullptr, 2, pc.c_str(), 0), POTMAP_ERROR_NULL_ARGUMENT);
  for (potmap_map* m : {am, bm, c}) potmap_map_destroy(m);
  potmap_drive_mapper_destroy(a);
  potmap_drive_mapper_destroy(b);
  potmap_dataset_destroy(data);
}
