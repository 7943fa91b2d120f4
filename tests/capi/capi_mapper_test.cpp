// The C API's datasets, source maps, dictionaries and POT/RePOT mappers: every error path, and
// results equal to the C++ API's (potmap::Mapper, build_dictionary, BHM) on the same input.
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "capi_test_support.hpp"
#include "potmap/data/labelling.hpp"
#include "potmap/learn/bhm.hpp"
#include "potmap/learn/bhm_joint_merge.hpp"
#include "potmap/pot/atoms.hpp"
#include "potmap/pot/mapper.hpp"
#include "potmap/runtime/context.hpp"

using namespace capi_test;

namespace {

// The C++ side of the comparisons, on the same device as shared_context().
potmap::Context& cpp_context() {
  static potmap::Context ctx;
  return ctx;
}

potmap::Scan to_cpp(const RoomScan& r) {
  potmap::Scan s;
  s.dim = 2;
  s.max_range = r.max_range;
  s.pose2d = {r.x, r.y, r.yaw};
  s.timestamp = r.timestamp;
  s.hits = r.hits;
  s.no_return = r.no_return;
  return s;
}

potmap::KernelMap read_back(const potmap_map* m) {
  potmap::KernelMap k;
  std::size_t n = 0;
  EXPECT_EQ(potmap_map_size(m, &k.dim, &n), POTMAP_SUCCESS) << potmap_last_error();
  k.position.resize(n * k.dim);
  k.gamma.resize(n);
  k.w_mean.resize(n);
  k.w_var.resize(n);
  if (n > 0)
    EXPECT_EQ(potmap_map_read(m, k.position.data(), k.position.size(), k.gamma.data(),
                              k.w_mean.data(), k.w_var.data(), n),
              POTMAP_SUCCESS)
        << potmap_last_error();
  return k;
}

void expect_same(const potmap::KernelMap& a, const potmap::KernelMap& b, const char* what) {
  ASSERT_EQ(a.dim, b.dim) << what;
  ASSERT_EQ(a.size(), b.size()) << what;
  EXPECT_EQ(a.position, b.position) << what;
  EXPECT_EQ(a.gamma, b.gamma) << what;
  EXPECT_EQ(a.w_mean, b.w_mean) << what;
  EXPECT_EQ(a.w_var, b.w_var) << what;
}

// The source side shared by the tests: a BHM map of 6 room scans and their dictionary.
struct Source {
  std::vector<RoomScan> room = room_path(6);
  ScanList list{room};
  potmap_map* map = nullptr;
  potmap_dictionary* dict = nullptr;
  Source() {
    EXPECT_EQ(potmap_map_learn_bhm(shared_context(), list.data(), list.size(), 0, 0, &map),
              POTMAP_SUCCESS)
        << potmap_last_error();
    EXPECT_EQ(potmap_dictionary_build(list.data(), list.size(), map, nullptr, &dict),
              POTMAP_SUCCESS)
        << potmap_last_error();
  }
};
const Source& source() {
  static const Source s;
  return s;
}

// Target scans: the room seen from elsewhere.
std::vector<RoomScan> targets(std::size_t n) {
  std::vector<RoomScan> t;
  for (std::size_t i = 0; i < n; ++i)
    t.push_back(room_scan(3 + 1.5 * double(i), 4.5 + 0.5 * std::sin(double(i)), 1.0 + 0.7 * i));
  return t;
}

// The C++ API's dictionary of the source, as potmap_dictionary_build makes it.
std::shared_ptr<potmap::Dictionary> cpp_dictionary(const Source& src) {
  std::vector<potmap::Scan> src_scans;
  for (const RoomScan& r : src.room) src_scans.push_back(to_cpp(r));
  auto dict = std::make_shared<potmap::Dictionary>();
  potmap::build_dictionary(src_scans, read_back(src.map), {}, *dict);
  return dict;
}

// The paper's rules (the summed overall map, whose merges the tests count), four rotations.
potmap_mapper_options fast_options(int refine) {
  potmap_mapper_options o;
  potmap_mapper_options_init_paper(&o, sizeof o);
  o.rotations = 4;
  o.refine = refine;
  o.seed = 5;
  return o;
}

// What fast_options(refine) asks of the C++ Mapper (from `base`'s other settings).
potmap::MapperOptions cpp_options(
    int refine, const potmap::MapperOptions& base = potmap::MapperOptions::paper()) {
  potmap::MapperOptions mo = base;
  mo.pot.rotations = {0, kPi / 2, kPi, 3 * kPi / 2};
  mo.pot.refine = refine == 1;
  mo.pot.seed = mo.labels.seed = 5;
  return mo;
}

}  // namespace

TEST(CApiMapper, StructsInitToTheDocumentedDefaults) {
  potmap_scan s;
  std::memset(&s, 0xff, sizeof s);
  POTMAP_ASSERT_OK(potmap_scan_init(&s, sizeof s));
  EXPECT_EQ(s.struct_size, sizeof s);
  EXPECT_EQ(s.dim, 2);
  EXPECT_EQ(s.pose[0], 1.0);  // identity 3 x 4: 2D callers set pose[0..2] themselves
  EXPECT_EQ(s.max_range, 0.0);
  EXPECT_EQ(s.hits, nullptr);
  EXPECT_EQ(s.num_hits, 0u);

  potmap_mapper_options m;
  POTMAP_ASSERT_OK(potmap_mapper_options_init(&m, sizeof m));
  EXPECT_EQ(m.sectors, 5);
  EXPECT_EQ(m.rotations, 8);
  EXPECT_EQ(m.refine, 0);
  EXPECT_EQ(m.holdout_fraction, 0.2);
  EXPECT_EQ(m.merge_radius, 0.25);
  EXPECT_EQ(m.gamma_ratio, 2.0);
  EXPECT_EQ(m.max_kernels, 0u);
  EXPECT_EQ(m.persistent_refine, 1);
  // The library's defaults, which map real logs best.
  EXPECT_EQ(m.ranking, POTMAP_RANKING_INDEXED);
  EXPECT_EQ(m.placement, POTMAP_PLACEMENT_AUTO);
  EXPECT_EQ(m.anchor_spacing, 0.5);
  EXPECT_EQ(m.wall_clearance, 0.5);
  EXPECT_EQ(m.anchor_clearance, 0.25);
  EXPECT_EQ(m.anchor_sweeps, 10);
  EXPECT_EQ(m.logit_gain, 1.5);
  EXPECT_EQ(m.average_overall, 1);
  EXPECT_EQ(m.async_merge, 0);
  EXPECT_EQ(m.seeds_yield_fully, 1);
  EXPECT_EQ(m.refine_spacing, 0.5);
  EXPECT_EQ(m.refine_prior_var, 10.0);
  EXPECT_EQ(m.refine_em_iterations, 3);
  EXPECT_EQ(m.seed_displacement_variance, 0.25);
  EXPECT_EQ(m.half_life, 0.0);
  // The paper's rules: the defaults but for the five the preset sets.
  potmap_mapper_options mp;
  POTMAP_ASSERT_OK(potmap_mapper_options_init_paper(&mp, sizeof mp));
  EXPECT_EQ(mp.ranking, POTMAP_RANKING_EXHAUSTIVE);
  EXPECT_EQ(mp.placement, POTMAP_PLACEMENT_BARYCENTRIC);
  EXPECT_EQ(mp.wall_clearance, 0.0);
  EXPECT_EQ(mp.average_overall, 0);
  EXPECT_EQ(mp.seed_displacement_variance, 0.0);
  EXPECT_EQ(mp.sectors, m.sectors);
  EXPECT_EQ(mp.rotations, m.rotations);
  EXPECT_EQ(mp.holdout_fraction, m.holdout_fraction);
  EXPECT_EQ(mp.merge_radius, m.merge_radius);
  EXPECT_EQ(mp.persistent_refine, m.persistent_refine);
  EXPECT_EQ(mp.refine_spacing, m.refine_spacing);
  POTMAP_EXPECT_FAIL(potmap_mapper_options_init_paper(nullptr, sizeof mp),
                     POTMAP_ERROR_NULL_ARGUMENT);
  // `potmap map`'s settings: the defaults but for its seeds' displacement variance.
  potmap_mapper_options md;
  POTMAP_ASSERT_OK(potmap_mapper_options_init_map_defaults(&md, sizeof md));
  EXPECT_EQ(md.ranking, m.ranking);
  EXPECT_EQ(md.placement, m.placement);
  EXPECT_EQ(md.wall_clearance, m.wall_clearance);
  EXPECT_EQ(md.average_overall, m.average_overall);
  EXPECT_EQ(md.seed_displacement_variance, 0.0);
  // Field by field (a struct's padding bytes are not its value).
  EXPECT_EQ(md.sectors, m.sectors);
  EXPECT_EQ(md.rotations, m.rotations);
  EXPECT_EQ(md.refine, m.refine);
  EXPECT_EQ(md.max_range, m.max_range);
  EXPECT_EQ(md.candidates, m.candidates);
  EXPECT_EQ(md.holdout_fraction, m.holdout_fraction);
  EXPECT_EQ(md.free_per_metre, m.free_per_metre);
  EXPECT_EQ(md.seed, m.seed);
  EXPECT_EQ(md.merge_radius, m.merge_radius);
  EXPECT_EQ(md.gamma_ratio, m.gamma_ratio);
  EXPECT_EQ(md.max_kernels, m.max_kernels);
  EXPECT_EQ(md.persistent_refine, m.persistent_refine);
  EXPECT_EQ(md.anchor_spacing, m.anchor_spacing);
  POTMAP_EXPECT_FAIL(potmap_mapper_options_init_map_defaults(nullptr, sizeof md),
                     POTMAP_ERROR_NULL_ARGUMENT);
  POTMAP_EXPECT_FAIL(potmap_mapper_options_init_map_defaults(&md, 4),
                     POTMAP_ERROR_INVALID_ARGUMENT);

  potmap_dictionary_options d;
  POTMAP_ASSERT_OK(potmap_dictionary_options_init(&d, sizeof d));
  EXPECT_EQ(d.sectors, 5);
  EXPECT_EQ(d.scale, 1.0 / 50.0);
  EXPECT_EQ(d.max_weight_variance, 1000.0);

  POTMAP_EXPECT_FAIL(potmap_scan_init(nullptr, sizeof s), POTMAP_ERROR_NULL_ARGUMENT);
  POTMAP_EXPECT_FAIL(potmap_scan_init(&s, 8), POTMAP_ERROR_INVALID_ARGUMENT);
  EXPECT_TRUE(contains(potmap_last_error(), "struct_size")) << potmap_last_error();
  POTMAP_EXPECT_FAIL(potmap_mapper_options_init(&m, 0), POTMAP_ERROR_INVALID_ARGUMENT);
  POTMAP_EXPECT_FAIL(potmap_dictionary_options_init(&d, sizeof d - 1),
                     POTMAP_ERROR_INVALID_ARGUMENT);
  POTMAP_EXPECT_FAIL(potmap_mapper_options_init(nullptr, sizeof m), POTMAP_ERROR_NULL_ARGUMENT);
}

TEST(CApiMapper, DatasetReadsALogAndChecksIndices) {
  potmap_dataset* data = nullptr;
  POTMAP_ASSERT_OK(
      potmap_dataset_load(shared_data("radish/intel-corrected.log.gz").c_str(), &data));
  size_t n = 0;
  POTMAP_ASSERT_OK(potmap_dataset_size(data, &n));
  EXPECT_EQ(n, 910u);
  potmap_scan s;
  POTMAP_ASSERT_OK(potmap_scan_init(&s, sizeof s));
  POTMAP_ASSERT_OK(potmap_dataset_scan(data, 909, &s));
  EXPECT_EQ(s.dim, 2);
  EXPECT_EQ(s.num_hits + s.num_no_return, 180u);
  EXPECT_GT(s.max_range, 0);
  ASSERT_NE(s.hits, nullptr);
  EXPECT_TRUE(std::isfinite(s.hits[0]) && std::isfinite(s.pose[2]));

  POTMAP_EXPECT_FAIL(potmap_dataset_scan(data, 910, &s), POTMAP_ERROR_INVALID_ARGUMENT);
  EXPECT_TRUE(contains(potmap_last_error(), "910")) << potmap_last_error();
  POTMAP_EXPECT_FAIL(potmap_dataset_scan(data, 0, nullptr), POTMAP_ERROR_NULL_ARGUMENT);
  s.struct_size = 4;
  POTMAP_EXPECT_FAIL(potmap_dataset_scan(data, 0, &s), POTMAP_ERROR_INVALID_ARGUMENT);
  POTMAP_EXPECT_FAIL(potmap_dataset_size(data, nullptr), POTMAP_ERROR_NULL_ARGUMENT);
  POTMAP_EXPECT_FAIL(potmap_dataset_size(nullptr, &n), POTMAP_ERROR_NULL_ARGUMENT);
  POTMAP_ASSERT_OK(potmap_dataset_destroy(data));
  POTMAP_ASSERT_OK(potmap_dataset_destroy(nullptr));

  potmap_dataset* none = nullptr;
  const std::string missing = temp_dir("dataset") + "/missing.log";
  POTMAP_EXPECT_FAIL(potmap_dataset_load(missing.c_str(), &none), POTMAP_ERROR_INPUT);
  EXPECT_TRUE(contains(potmap_last_error(), "missing.log")) << potmap_last_error();
  EXPECT_EQ(none, nullptr);
  POTMAP_EXPECT_FAIL(potmap_dataset_load(nullptr, &none), POTMAP_ERROR_NULL_ARGUMENT);
}

TEST(CApiMapper, LearnBhmChecksEveryScan) {
  const std::vector<RoomScan> room = room_path(2);
  ScanList list(room);
  potmap_map* map = nullptr;
  potmap_context* ctx = shared_context();
  POTMAP_EXPECT_FAIL(potmap_map_learn_bhm(nullptr, list.data(), 2, 0, 0, &map),
                     POTMAP_ERROR_NULL_ARGUMENT);
  POTMAP_EXPECT_FAIL(potmap_map_learn_bhm(ctx, nullptr, 2, 0, 0, &map), POTMAP_ERROR_NULL_ARGUMENT);
  POTMAP_EXPECT_FAIL(potmap_map_learn_bhm(ctx, list.data(), 2, 0, 0, nullptr),
                     POTMAP_ERROR_NULL_ARGUMENT);
  POTMAP_EXPECT_FAIL(potmap_map_learn_bhm(ctx, list.data(), 0, 0, 0, &map),
                     POTMAP_ERROR_INVALID_ARGUMENT);
  POTMAP_EXPECT_FAIL(potmap_map_learn_bhm(ctx, list.data(), 2, -1, 0, &map),
                     POTMAP_ERROR_INVALID_ARGUMENT);
  POTMAP_EXPECT_FAIL(potmap_map_learn_bhm(ctx, list.data(), 2, 0, NAN, &map),
                     POTMAP_ERROR_INVALID_ARGUMENT);

  auto fails_on_second = [&](auto&& spoil, potmap_status expected, const char* word) {
    ScanList bad(room);
    spoil(bad.scans[1]);
    POTMAP_EXPECT_FAIL(potmap_map_learn_bhm(ctx, bad.data(), 2, 0, 0, &map), expected);
    EXPECT_TRUE(contains(potmap_last_error(), "scans[1]")) << potmap_last_error();
    EXPECT_TRUE(contains(potmap_last_error(), word)) << potmap_last_error();
  };
  fails_on_second([](potmap_scan& s) { s.dim = 4; }, POTMAP_ERROR_INVALID_ARGUMENT, "dim");
  fails_on_second([](potmap_scan& s) { s.max_range = 0; }, POTMAP_ERROR_INVALID_ARGUMENT,
                  "max_range");
  fails_on_second([](potmap_scan& s) { s.pose[2] = NAN; }, POTMAP_ERROR_INVALID_ARGUMENT,
                  "pose[2]");
  fails_on_second([](potmap_scan& s) { s.hits = nullptr; }, POTMAP_ERROR_NULL_ARGUMENT, "hits");
  fails_on_second([](potmap_scan& s) { s.struct_size = 0; }, POTMAP_ERROR_INVALID_ARGUMENT,
                  "struct_size");
  fails_on_second([](potmap_scan& s) { s.struct_size = sizeof(potmap_scan) + 8; },
                  POTMAP_ERROR_INVALID_ARGUMENT, "newer");
  // A 3D scan among 2D ones (its arrays hold enough doubles to be read as 3D).
  fails_on_second(
      [](potmap_scan& s) {
        s.dim = 3;
        s.num_hits = s.num_hits * 2 / 3;
        s.num_no_return = s.num_no_return * 2 / 3;
      },
      POTMAP_ERROR_DIMENSION_MISMATCH, "3D");
  const potmap_scan* holes[2] = {list.ptrs[0], nullptr};
  POTMAP_EXPECT_FAIL(potmap_map_learn_bhm(ctx, holes, 2, 0, 0, &map), POTMAP_ERROR_NULL_ARGUMENT);
  EXPECT_EQ(map, nullptr);
}

TEST(CApiMapper, LearnBhmAndDictionaryMatchTheCppApi) {
  const Source& src = source();
  ASSERT_NE(src.dict, nullptr);
  // The C++ API on the same scans: label every beam, grid prior (1 m, gamma 8), sequential BHM.
  std::vector<potmap::Scan> scans;
  for (const RoomScan& r : src.room) scans.push_back(to_cpp(r));
  potmap::LabelOptions lo;
  lo.holdout_fraction = 0;
  const potmap::LabelledSplit split = potmap::label_scans(scans, lo);
  double lo3[3] = {INFINITY, INFINITY, 0}, hi3[3] = {-INFINITY, -INFINITY, 0};
  for (std::size_t i = 0; i < split.train.size(); ++i)
    for (int d = 0; d < 2; ++d) {
      lo3[d] = std::min(lo3[d], split.train.position[2 * i + d]);
      hi3[d] = std::max(hi3[d], split.train.position[2 * i + d]);
    }
  potmap::KernelMap map = potmap::bhm_grid_prior(2, lo3, hi3, 1.0, 8.0);
  potmap::bhm_update_sequential(&cpp_context(), map, split.train);
  const potmap::KernelMap from_c = read_back(src.map);
  expect_same(from_c, map, "BHM map");

  potmap::Dictionary dict;
  potmap::build_dictionary(scans, map, {}, dict);
  int dim = 0, sectors = 0;
  size_t atoms = 0, kernels = 0;
  double scale = 0, max_range = 0;
  POTMAP_ASSERT_OK(
      potmap_dictionary_info(src.dict, &dim, &atoms, &kernels, &scale, &max_range, &sectors));
  std::size_t cpp_kernels = 0;
  for (const potmap::Atom& a : dict.atoms) cpp_kernels += a.kernels.size();
  EXPECT_EQ(dim, 2);
  EXPECT_EQ(atoms, dict.size());
  EXPECT_GE(atoms, 20u);  // 6 scans x 5 sectors, a few sparse ones dropped at most
  EXPECT_EQ(kernels, cpp_kernels);
  EXPECT_EQ(scale, dict.scale);
  EXPECT_EQ(max_range, 6.0);
  EXPECT_EQ(sectors, 5);
  POTMAP_ASSERT_OK(
      potmap_dictionary_info(src.dict, nullptr, nullptr, nullptr, nullptr, nullptr, nullptr));
}

TEST(CApiMapper, DictionaryRoundTripsAndRefusesBadInput) {
  const Source& src = source();
  const std::string dir = temp_dir("dict");
  const std::string a = dir + "/a.potdict", b = dir + "/b.potdict";
  POTMAP_ASSERT_OK(potmap_dictionary_save(src.dict, a.c_str()));
  potmap_dictionary* back = nullptr;
  POTMAP_ASSERT_OK(potmap_dictionary_load(a.c_str(), &back));
  POTMAP_ASSERT_OK(potmap_dictionary_save(back, b.c_str()));
  auto bytes = [](const std::string& p) {
    std::ifstream f(p, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(f), {});
  };
  EXPECT_EQ(bytes(a), bytes(b));
  EXPECT_GT(bytes(a).size(), 1000u);
  POTMAP_ASSERT_OK(potmap_dictionary_destroy(back));

  potmap_dictionary* none = nullptr;
  POTMAP_EXPECT_FAIL(potmap_dictionary_load((dir + "/missing.potdict").c_str(), &none),
                     POTMAP_ERROR_INPUT);
  std::string cut = bytes(a);
  write_text(dir + "/cut.potdict", cut.substr(0, cut.size() / 2));
  POTMAP_EXPECT_FAIL(potmap_dictionary_load((dir + "/cut.potdict").c_str(), &none),
                     POTMAP_ERROR_INPUT);
  EXPECT_TRUE(contains(potmap_last_error(), "cut.potdict")) << potmap_last_error();
  cut[cut.size() / 2] ^= 0x5a;
  write_text(dir + "/flip.potdict", cut);
  POTMAP_EXPECT_FAIL(potmap_dictionary_load((dir + "/flip.potdict").c_str(), &none),
                     POTMAP_ERROR_INPUT);
  EXPECT_EQ(none, nullptr);
  write_text(dir + "/a-file", "x");  // no folder can be made under it
  POTMAP_EXPECT_FAIL(potmap_dictionary_save(src.dict, (dir + "/a-file/dir/d.potdict").c_str()),
                     POTMAP_ERROR_IO);
  POTMAP_EXPECT_FAIL(potmap_dictionary_save(src.dict, nullptr), POTMAP_ERROR_NULL_ARGUMENT);
  POTMAP_EXPECT_FAIL(potmap_dictionary_save(nullptr, a.c_str()), POTMAP_ERROR_NULL_ARGUMENT);
  int dim = 0;
  POTMAP_EXPECT_FAIL(
      potmap_dictionary_info(nullptr, &dim, nullptr, nullptr, nullptr, nullptr, nullptr),
      POTMAP_ERROR_NULL_ARGUMENT);
}

TEST(CApiMapper, DictionaryBuildChecksMapAndOptions) {
  const Source& src = source();
  potmap_dictionary* d = nullptr;
  POTMAP_EXPECT_FAIL(
      potmap_dictionary_build(src.list.data(), src.list.size(), nullptr, nullptr, &d),
      POTMAP_ERROR_NULL_ARGUMENT);
  POTMAP_EXPECT_FAIL(potmap_dictionary_build(nullptr, 1, src.map, nullptr, &d),
                     POTMAP_ERROR_NULL_ARGUMENT);
  // A handle of another type.
  POTMAP_EXPECT_FAIL(
      potmap_dictionary_build(src.list.data(), src.list.size(),
                              reinterpret_cast<const potmap_map*>(src.dict), nullptr, &d),
      POTMAP_ERROR_INVALID_HANDLE);
  // A 3D map with 2D scans.
  const Arrays a3 = random_map(3, 10, 4);
  potmap_map* map3 = make_map(a3);
  POTMAP_EXPECT_FAIL(potmap_dictionary_build(src.list.data(), src.list.size(), map3, nullptr, &d),
                     POTMAP_ERROR_DIMENSION_MISMATCH);
  POTMAP_ASSERT_OK(potmap_map_destroy(map3));
  // Bad options.
  potmap_dictionary_options o;
  POTMAP_ASSERT_OK(potmap_dictionary_options_init(&o, sizeof o));
  o.sectors = 0;
  POTMAP_EXPECT_FAIL(potmap_dictionary_build(src.list.data(), src.list.size(), src.map, &o, &d),
                     POTMAP_ERROR_INVALID_ARGUMENT);
  EXPECT_TRUE(contains(potmap_last_error(), "sectors")) << potmap_last_error();
  POTMAP_ASSERT_OK(potmap_dictionary_options_init(&o, sizeof o));
  o.scale = -1;
  POTMAP_EXPECT_FAIL(potmap_dictionary_build(src.list.data(), src.list.size(), src.map, &o, &d),
                     POTMAP_ERROR_INVALID_ARGUMENT);
  o.struct_size = 0;
  POTMAP_EXPECT_FAIL(potmap_dictionary_build(src.list.data(), src.list.size(), src.map, &o, &d),
                     POTMAP_ERROR_INVALID_ARGUMENT);
  // A map far from every scan: no atom has kernels.
  const double far[2] = {500, 500}, g = 1, wm = 1, wv = 0.1;
  potmap_map* away = nullptr;
  POTMAP_ASSERT_OK(potmap_map_create(2, 1, far, &g, &wm, &wv, &away));
  POTMAP_EXPECT_FAIL(potmap_dictionary_build(src.list.data(), src.list.size(), away, nullptr, &d),
                     POTMAP_ERROR_INVALID_ARGUMENT);
  EXPECT_TRUE(contains(potmap_last_error(), "no atom")) << potmap_last_error();
  POTMAP_ASSERT_OK(potmap_map_destroy(away));
  EXPECT_EQ(d, nullptr);
  // Options with more sectors are honoured.
  POTMAP_ASSERT_OK(potmap_dictionary_options_init(&o, sizeof o));
  o.sectors = 8;
  POTMAP_ASSERT_OK(potmap_dictionary_build(src.list.data(), src.list.size(), src.map, &o, &d));
  int sectors = 0;
  POTMAP_ASSERT_OK(
      potmap_dictionary_info(d, nullptr, nullptr, nullptr, nullptr, nullptr, &sectors));
  EXPECT_EQ(sectors, 8);
  POTMAP_ASSERT_OK(potmap_dictionary_destroy(d));
}

TEST(CApiMapper, MapperChecksItsArgumentsAndStaysUnchangedOnFailure) {
  const Source& src = source();
  potmap_context* ctx = shared_context();
  potmap_mapper* m = nullptr;
  potmap_mapper_options o = fast_options(0);
  POTMAP_EXPECT_FAIL(potmap_mapper_create(nullptr, src.dict, &o, &m), POTMAP_ERROR_NULL_ARGUMENT);
  POTMAP_EXPECT_FAIL(potmap_mapper_create(ctx, nullptr, &o, &m), POTMAP_ERROR_NULL_ARGUMENT);
  POTMAP_EXPECT_FAIL(potmap_mapper_create(ctx, src.dict, &o, nullptr), POTMAP_ERROR_NULL_ARGUMENT);
  POTMAP_EXPECT_FAIL(
      potmap_mapper_create(ctx, reinterpret_cast<const potmap_dictionary*>(src.map), &o, &m),
      POTMAP_ERROR_INVALID_HANDLE);
  auto bad_option = [&](auto&& spoil, const char* field) {
    potmap_mapper_options b = fast_options(0);
    spoil(b);
    POTMAP_EXPECT_FAIL(potmap_mapper_create(ctx, src.dict, &b, &m), POTMAP_ERROR_INVALID_ARGUMENT);
    EXPECT_TRUE(contains(potmap_last_error(), field)) << potmap_last_error();
  };
  bad_option([](potmap_mapper_options& b) { b.rotations = 0; }, "rotations");
  bad_option([](potmap_mapper_options& b) { b.sectors = 0; }, "sectors");
  bad_option([](potmap_mapper_options& b) { b.refine = 2; }, "refine");
  bad_option([](potmap_mapper_options& b) { b.persistent_refine = -1; }, "persistent_refine");
  bad_option([](potmap_mapper_options& b) { b.ranking = 2; }, "ranking");
  bad_option([](potmap_mapper_options& b) { b.placement = -1; }, "placement");
  bad_option([](potmap_mapper_options& b) { b.placement = 3; }, "placement");
  bad_option([](potmap_mapper_options& b) { b.anchor_spacing = 0; }, "anchor_spacing");
  bad_option([](potmap_mapper_options& b) { b.wall_clearance = -0.1; }, "wall_clearance");
  bad_option([](potmap_mapper_options& b) { b.wall_clearance = INFINITY; }, "wall_clearance");
  bad_option([](potmap_mapper_options& b) { b.average_overall = 2; }, "average_overall");
  bad_option([](potmap_mapper_options& b) { b.holdout_fraction = 1; }, "holdout_fraction");
  bad_option([](potmap_mapper_options& b) { b.free_per_metre = 0; }, "free_per_metre");
  bad_option([](potmap_mapper_options& b) { b.gamma_ratio = 0.5; }, "gamma_ratio");
  bad_option([](potmap_mapper_options& b) { b.max_range = NAN; }, "max_range");
  bad_option([](potmap_mapper_options& b) { b.refine_spacing = 0; }, "refine_spacing");
  bad_option([](potmap_mapper_options& b) { b.refine_spacing = NAN; }, "refine_spacing");
  bad_option([](potmap_mapper_options& b) { b.refine_prior_var = -1; }, "refine_prior_var");
  bad_option([](potmap_mapper_options& b) { b.refine_em_iterations = 0; }, "refine_em_iterations");
  bad_option([](potmap_mapper_options& b) { b.refine_em_iterations = 101; },
             "refine_em_iterations");
  bad_option([](potmap_mapper_options& b) { b.half_life = -1; }, "half_life");
  bad_option([](potmap_mapper_options& b) { b.half_life = NAN; }, "half_life");
  bad_option([](potmap_mapper_options& b) { b.anchor_clearance = -1; }, "anchor_clearance");
  bad_option([](potmap_mapper_options& b) { b.anchor_sweeps = -1; }, "anchor_sweeps");
  bad_option([](potmap_mapper_options& b) { b.logit_gain = 0; }, "logit_gain");
  bad_option([](potmap_mapper_options& b) { b.logit_gain = NAN; }, "logit_gain");
  bad_option([](potmap_mapper_options& b) { b.struct_size = 3; }, "struct_size");
  bad_option([](potmap_mapper_options& b) { b.struct_size = 4096; }, "newer");
  EXPECT_EQ(m, nullptr);
  {
    // A caller compiled against the first version (no persistent_refine) still works, and
    // gets the default for it.
    // A caller whose struct ends at `size`: a mapper made with `opts` (its fields beyond
    // `size` never read), and in `out` what `init` writes into a struct of 0xff bytes of that
    // size.
    auto old_caller = [&](potmap_mapper_options opts, size_t size,
                          potmap_status (*init)(potmap_mapper_options*, size_t),
                          potmap_mapper_options& out) {
      opts.struct_size = size;
      potmap_mapper* made = nullptr;
      POTMAP_ASSERT_OK(potmap_mapper_create(ctx, src.dict, &opts, &made));
      POTMAP_ASSERT_OK(potmap_mapper_destroy(made));
      std::memset(&out, 0xff, sizeof out);
      POTMAP_ASSERT_OK(init(&out, size));
    };
    potmap_mapper_options v1 = fast_options(1), init_v1;
    v1.persistent_refine = 7;  // beyond the caller's struct: never read
    ASSERT_NO_FATAL_FAILURE(old_caller(v1, offsetof(potmap_mapper_options, persistent_refine),
                                       potmap_mapper_options_init, init_v1));
    EXPECT_EQ(init_v1.persistent_refine, -1);  // not written: beyond the caller's struct
    EXPECT_EQ(init_v1.sectors, 5);
    // The same for a caller of version 2 (no ranking, placement, ...), with either _init.
    potmap_mapper_options v2 = fast_options(0), init_v2;
    v2.ranking = 9;  // beyond the caller's struct: never read
    ASSERT_NO_FATAL_FAILURE(old_caller(v2, offsetof(potmap_mapper_options, ranking),
                                       potmap_mapper_options_init_map_defaults, init_v2));
    EXPECT_EQ(init_v2.ranking, -1);
    EXPECT_EQ(init_v2.average_overall, -1);
    EXPECT_EQ(init_v2.persistent_refine, 1);
    // A caller of version 5 (no refine_spacing, ...): bad values beyond its struct are never
    // read, and _init leaves them alone.
    potmap_mapper_options v5 = fast_options(1), init_v5;
    v5.refine_spacing = -1;
    v5.refine_em_iterations = 0;
    ASSERT_NO_FATAL_FAILURE(old_caller(v5, offsetof(potmap_mapper_options, refine_spacing),
                                       potmap_mapper_options_init, init_v5));
    EXPECT_EQ(init_v5.refine_em_iterations, -1);
    EXPECT_EQ(init_v5.seeds_yield_fully, 1);
  }

  POTMAP_ASSERT_OK(potmap_mapper_create(ctx, src.dict, &o, &m));
  const RoomScan target = targets(1)[0];
  potmap_scan s = target.scan();
  potmap_scan_stats st;
  st.struct_size = sizeof st;
  POTMAP_EXPECT_FAIL(potmap_mapper_add_scan(nullptr, &s, &st), POTMAP_ERROR_NULL_ARGUMENT);
  POTMAP_EXPECT_FAIL(potmap_mapper_add_scan(m, nullptr, &st), POTMAP_ERROR_NULL_ARGUMENT);
  potmap_scan s3 = s;
  s3.dim = 3;
  s3.num_hits = s.num_hits * 2 / 3;
  s3.num_no_return = s.num_no_return * 2 / 3;
  POTMAP_EXPECT_FAIL(potmap_mapper_add_scan(m, &s3, &st), POTMAP_ERROR_DIMENSION_MISMATCH);
  potmap_scan_stats small;
  small.struct_size = sizeof(size_t);
  POTMAP_EXPECT_FAIL(potmap_mapper_add_scan(m, &s, &small), POTMAP_ERROR_BUFFER_TOO_SMALL);
  potmap_scan nan_range = s;
  nan_range.max_range = NAN;
  POTMAP_EXPECT_FAIL(potmap_mapper_add_scan(m, &nan_range, &st), POTMAP_ERROR_INVALID_ARGUMENT);
  potmap_map* out = nullptr;
  POTMAP_EXPECT_FAIL(potmap_mapper_overall_map(m, nullptr), POTMAP_ERROR_NULL_ARGUMENT);
  POTMAP_EXPECT_FAIL(potmap_mapper_instantaneous_map(nullptr, &out), POTMAP_ERROR_NULL_ARGUMENT);
  POTMAP_EXPECT_FAIL(potmap_mapper_reset(nullptr), POTMAP_ERROR_NULL_ARGUMENT);

  // None of the failures mapped anything: the overall map is empty, the next scan is number 0.
  POTMAP_ASSERT_OK(potmap_mapper_overall_map(m, &out));
  int dim = 0;
  size_t n = 1;
  POTMAP_ASSERT_OK(potmap_map_size(out, &dim, &n));
  EXPECT_EQ(dim, 2);
  EXPECT_EQ(n, 0u);
  POTMAP_ASSERT_OK(potmap_map_destroy(out));
  POTMAP_ASSERT_OK(potmap_mapper_add_scan(m, &s, &st));
  EXPECT_EQ(st.scan_index, 0u);
  EXPECT_GT(st.kernels_placed, 0u);
  // stats may be null.
  POTMAP_ASSERT_OK(potmap_mapper_add_scan(m, &s, nullptr));
  POTMAP_ASSERT_OK(potmap_mapper_destroy(m));
  POTMAP_ASSERT_OK(potmap_mapper_destroy(nullptr));
}

// POT and RePOT through the C API give what potmap::Mapper gives on the same scans, scan by
// scan and in the overall map; reset starts over exactly.
TEST(CApiMapper, MapperMatchesTheCppMapper) {
  const Source& src = source();
  const std::vector<RoomScan> tgt = targets(4);
  std::vector<potmap::Scan> cpp_scans;
  for (const RoomScan& r : tgt) cpp_scans.push_back(to_cpp(r));
  const auto dict = cpp_dictionary(src);

  for (int refine = 0; refine <= 1; ++refine) {
    SCOPED_TRACE(refine ? "RePOT" : "POT");
    const potmap_mapper_options o = fast_options(refine);
    potmap_mapper* m = nullptr;
    POTMAP_ASSERT_OK(potmap_mapper_create(shared_context(), src.dict, &o, &m));
    potmap::MapperOptions mo = cpp_options(refine);
    potmap::Mapper cpp(&cpp_context(), dict, mo);

    std::vector<potmap::KernelMap> first_pass;
    for (int pass = 0; pass < 2; ++pass) {
      std::size_t sum_placed = 0;
      for (std::size_t i = 0; i < tgt.size(); ++i) {
        const potmap_scan s = tgt[i].scan();
        potmap_scan_stats st;
        st.struct_size = sizeof st;
        POTMAP_ASSERT_OK(potmap_mapper_add_scan(m, &s, &st));
        potmap_map* inst = nullptr;
        POTMAP_ASSERT_OK(potmap_mapper_instantaneous_map(m, &inst));
        const potmap::KernelMap got = read_back(inst);
        POTMAP_ASSERT_OK(potmap_map_destroy(inst));
        if (pass == 0) {
          const potmap::MappedScan& want = cpp.add_scan(cpp_scans[i]);
          expect_same(got, want.transfer.map, "instantaneous map");
          EXPECT_EQ(st.heldout_samples, want.test.size());
          EXPECT_EQ(st.overall_kernels, cpp.overall_kernels());
          EXPECT_EQ(st.overall_added, cpp.last_merge().stats.added);
          EXPECT_EQ(st.overall_merged, cpp.last_merge().stats.merged);
          first_pass.push_back(got);
        } else {
          expect_same(got, first_pass[i], "instantaneous map after reset");
        }
        EXPECT_EQ(st.scan_index, i);
        EXPECT_EQ(st.kernels_placed, got.size());
        EXPECT_GT(st.kernels_placed, 0u);
        EXPECT_GT(st.sectors, 0u);
        EXPECT_GT(st.train_samples, 0u);
        EXPECT_GT(st.heldout_samples, 0u);  // 20 % of the beams by default
        // RePOT's persistent map seeds and learns instead of merging.
        EXPECT_EQ(st.overall_added + st.overall_merged, refine ? 0u : st.kernels_placed);
        EXPECT_GT(st.overall_kernels, 0u);
        EXPECT_GE(st.total_ms, st.ranking_ms + st.transport_ms);
        EXPECT_EQ(st.refine_ms > 0, refine == 1);
        sum_placed += st.kernels_placed;
      }
      potmap_map* overall = nullptr;
      POTMAP_ASSERT_OK(potmap_mapper_overall_map(m, &overall));
      const potmap::KernelMap got = read_back(overall);
      if (pass == 0) expect_same(got, cpp.overall_map(), "overall map");
      if (refine) {
        int has_bias = 0;
        double bm = 0, bv = 0;
        POTMAP_ASSERT_OK(potmap_map_bias(overall, &has_bias, &bm, &bv));
        EXPECT_EQ(has_bias, 1);  // the persistent joint BHM's bias weight
      } else {
        EXPECT_LT(got.size(), sum_placed);  // overlapping scans: kernels merged
      }
      POTMAP_ASSERT_OK(potmap_map_destroy(overall));
      POTMAP_ASSERT_OK(potmap_mapper_reset(m));
    }
    POTMAP_ASSERT_OK(potmap_mapper_destroy(m));
  }
}

// async_merge: add_scan hands the scan back before its merge; the overall map read afterwards
// (which waits for the merge in flight) is the synchronous mapper's, bit for bit, and a saved
// state too. A value other than 0 or 1 is refused, naming the field.
TEST(CApiMapper, AsyncMergeMapsAsTheSynchronousMapper) {
  const Source& src = source();
  const std::vector<RoomScan> tgt = targets(4);
  for (int refine = 0; refine <= 1; ++refine) {
    SCOPED_TRACE(refine ? "RePOT" : "POT");
    potmap_mapper_options o = fast_options(refine);
    potmap_mapper *sync = nullptr, *behind = nullptr;
    POTMAP_ASSERT_OK(potmap_mapper_create(shared_context(), src.dict, &o, &sync));
    o.async_merge = 1;
    POTMAP_ASSERT_OK(potmap_mapper_create(shared_context(), src.dict, &o, &behind));
    for (const RoomScan& r : tgt) {
      const potmap_scan s = r.scan();
      POTMAP_ASSERT_OK(potmap_mapper_add_scan(sync, &s, nullptr));
      POTMAP_ASSERT_OK(potmap_mapper_add_scan(behind, &s, nullptr));
    }
    potmap_map *a = nullptr, *b = nullptr;
    POTMAP_ASSERT_OK(potmap_mapper_overall_map(sync, &a));
    POTMAP_ASSERT_OK(potmap_mapper_overall_map(behind, &b));
    expect_same(read_back(b), read_back(a), "overall map");
    EXPECT_GT(read_back(b).size(), 0u);
    POTMAP_ASSERT_OK(potmap_map_destroy(a));
    POTMAP_ASSERT_OK(potmap_map_destroy(b));
    POTMAP_ASSERT_OK(potmap_mapper_destroy(sync));
    POTMAP_ASSERT_OK(potmap_mapper_destroy(behind));  // with nothing in flight or a merge: fine
  }
  potmap_mapper_options bad = fast_options(0);
  bad.async_merge = 2;
  potmap_mapper* m = nullptr;
  POTMAP_EXPECT_FAIL(potmap_mapper_create(shared_context(), src.dict, &bad, &m),
                     POTMAP_ERROR_INVALID_ARGUMENT);
  EXPECT_TRUE(contains(potmap_last_error(), "async_merge")) << potmap_last_error();
  EXPECT_EQ(m, nullptr);
}

namespace {

// Overall maps of `scans` target scans: a C mapper with `o`, the C++ Mapper with `mo` (the same
// settings) and the C++ Mapper with the defaults of cpp_options(1).
struct ThreeMaps {
  potmap::KernelMap c, cpp, plain;
};
ThreeMaps persistent_maps(const potmap_mapper_options& o, const potmap::MapperOptions& mo,
                          std::size_t scans) {
  const Source& src = source();
  const auto dict = cpp_dictionary(src);
  potmap_mapper* m = nullptr;
  ThreeMaps r;
  EXPECT_EQ(potmap_mapper_create(shared_context(), src.dict, &o, &m), POTMAP_SUCCESS)
      << potmap_last_error();
  if (!m) return r;
  potmap::Mapper same(&cpp_context(), dict, mo);
  potmap::Mapper plain(&cpp_context(), dict, cpp_options(1));
  double time = 0;
  for (RoomScan t : targets(scans)) {
    t.timestamp = time++;  // a second apart: the mappers' clock (forgetting)
    const potmap_scan s = t.scan();
    EXPECT_EQ(potmap_mapper_add_scan(m, &s, nullptr), POTMAP_SUCCESS) << potmap_last_error();
    same.add_scan(to_cpp(t));
    plain.add_scan(to_cpp(t));
  }
  potmap_map* got = nullptr;
  EXPECT_EQ(potmap_mapper_overall_map(m, &got), POTMAP_SUCCESS);
  r.c = read_back(got);
  r.cpp = same.overall_map();
  r.plain = plain.overall_map();
  potmap_map_destroy(got);
  potmap_mapper_destroy(m);
  return r;
}

}  // namespace

// seeds_yield_fully reaches RePOT's persistent map: 0 (the seeded start kept) gives the C++
// mapper's map with the same rule, and a map other than the default rule's.
TEST(CApiMapper, SeedsYieldFullyReachesThePersistentMap) {
  potmap_mapper_options o = fast_options(1);
  o.seeds_yield_fully = 0;
  potmap::MapperOptions mo = cpp_options(1);
  mo.refine_map.seeds_yield_fully = false;
  const ThreeMaps maps = persistent_maps(o, mo, 4);
  expect_same(maps.c, maps.cpp, "overall map");
  EXPECT_NE(maps.c.w_mean, maps.plain.w_mean);
  potmap_mapper_options bad = fast_options(1);
  bad.seeds_yield_fully = -1;
  potmap_mapper* m = nullptr;
  POTMAP_EXPECT_FAIL(potmap_mapper_create(shared_context(), source().dict, &bad, &m),
                     POTMAP_ERROR_INVALID_ARGUMENT);
  EXPECT_TRUE(contains(potmap_last_error(), "seeds_yield_fully")) << potmap_last_error();
}

// refine_spacing, refine_prior_var and refine_em_iterations reach RePOT's persistent map: the C
// mapper gives the C++ mapper's map with the same JointBhmOptions, its kernels at twice the
// default's pitch.
TEST(CApiMapper, PersistentMapSettingsReachTheMapper) {
  potmap_mapper_options o = fast_options(1);
  o.refine_spacing = 1.0;
  o.refine_prior_var = 5.0;
  o.refine_em_iterations = 2;
  potmap::MapperOptions mo = cpp_options(1);
  mo.refine_map.spacing = 1.0;
  mo.refine_map.prior_var = 5.0;
  mo.refine_map.em_iterations = 2;
  const ThreeMaps maps = persistent_maps(o, mo, 3);
  expect_same(maps.c, maps.cpp, "overall map");
  // Kernels 1 m apart, where the default map's are 0.5 m apart.
  auto pitch = [](const potmap::KernelMap& km) {
    double p = HUGE_VAL;
    for (std::size_t a = 1; a < km.size(); ++a)
      if (km.position[2 * a + 1] == km.position[1] && km.position[2 * a] != km.position[0])
        p = std::min(p, std::abs(km.position[2 * a] - km.position[0]));
    return p;
  };
  EXPECT_NEAR(pitch(maps.c), 1.0, 1e-9);
  EXPECT_NEAR(pitch(maps.plain), 0.5, 1e-9);
}

// half_life reaches RePOT's persistent map, whose clock is the scans' timestamps: the C mapper
// gives the C++ mapper's map with the same half-life, and a map other than one that never
// forgets.
TEST(CApiMapper, HalfLifeReachesThePersistentMap) {
  potmap_mapper_options o = fast_options(1);
  o.half_life = 0.5;
  potmap::MapperOptions mo = cpp_options(1);
  mo.refine_map.half_life = 0.5;
  const ThreeMaps maps = persistent_maps(o, mo, 4);
  expect_same(maps.c, maps.cpp, "overall map");
  EXPECT_NE(maps.c.w_mean, maps.plain.w_mean);
}

// potmap_mapper_options_init_map_defaults maps as the C++ Mapper with `potmap map`'s settings
// (tools/cmd_map.cpp): indexed ranking, kernels on the scans' samples for POT and barycentric
// seeds for RePOT's persistent map, the 0.5 m wall clearance, the averaged overall map.
TEST(CApiMapper, MapDefaultsMapAsThePotmapMapCommand) {
  const Source& src = source();
  const std::vector<RoomScan> tgt = targets(3);
  const auto dict = cpp_dictionary(src);
  for (int refine = 0; refine <= 1; ++refine) {
    SCOPED_TRACE(refine ? "RePOT" : "POT");
    potmap_mapper_options o;
    POTMAP_ASSERT_OK(potmap_mapper_options_init_map_defaults(&o, sizeof o));
    o.rotations = 4;
    o.refine = refine;
    o.seed = 5;
    potmap_mapper* m = nullptr;
    POTMAP_ASSERT_OK(potmap_mapper_create(shared_context(), src.dict, &o, &m));
    // The library's defaults are potmap map's, but for its seeds.
    potmap::MapperOptions mo = cpp_options(refine, potmap::MapperOptions{});
    mo.seed_displacement_variance = 0;
    potmap::Mapper cpp(&cpp_context(), dict, mo);
    potmap::MapperOptions paper = mo;  // the same but for the four settings
    paper.pot.ranking = potmap::PotRanking::exhaustive;
    paper.pot.placement = potmap::PotPlacement::barycentric;
    paper.pot.wall_clearance = 0;
    paper.average_overall = false;
    potmap::Mapper by_paper(&cpp_context(), dict, paper);
    std::size_t differ = 0;
    for (const RoomScan& r : tgt) {
      const potmap_scan s = r.scan();
      POTMAP_ASSERT_OK(potmap_mapper_add_scan(m, &s, nullptr));
      potmap_map* inst = nullptr;
      POTMAP_ASSERT_OK(potmap_mapper_instantaneous_map(m, &inst));
      const potmap::KernelMap got = read_back(inst);
      POTMAP_ASSERT_OK(potmap_map_destroy(inst));
      const potmap::Scan cs = to_cpp(r);
      expect_same(got, cpp.add_scan(cs).transfer.map, "instantaneous map");
      const potmap::KernelMap other = by_paper.add_scan(cs).transfer.map;
      differ += other.size() != got.size() || other.w_mean != got.w_mean;
    }
    potmap_map* overall = nullptr;
    POTMAP_ASSERT_OK(potmap_mapper_overall_map(m, &overall));
    expect_same(read_back(overall), cpp.overall_map(), "overall map");
    POTMAP_ASSERT_OK(potmap_map_destroy(overall));
    POTMAP_ASSERT_OK(potmap_mapper_destroy(m));
    // The settings do reach the mapper: the paper's rules give other maps.
    EXPECT_GT(differ, 0u);
  }
}

// Two mappers on one context and one dictionary, on two threads at once, give what each gives
// alone (the documented sharing rules).
TEST(CApiMapper, MappersShareAContextAndADictionaryAcrossThreads) {
  const Source& src = source();
  const std::vector<RoomScan> tgt = targets(3);
  auto run = [&](int refine, std::vector<double>* weights) {
    const potmap_mapper_options o = fast_options(refine);
    potmap_mapper* m = nullptr;
    if (potmap_mapper_create(shared_context(), src.dict, &o, &m) != POTMAP_SUCCESS) return;
    for (const RoomScan& r : tgt) {
      const potmap_scan s = r.scan();
      if (potmap_mapper_add_scan(m, &s, nullptr) != POTMAP_SUCCESS) break;
    }
    potmap_map* overall = nullptr;
    if (potmap_mapper_overall_map(m, &overall) == POTMAP_SUCCESS) {
      *weights = read_back(overall).w_mean;
      potmap_map_destroy(overall);
    }
    potmap_mapper_destroy(m);
  };
  std::vector<double> alone[2], together[2];
  run(0, &alone[0]);
  run(1, &alone[1]);
  std::thread t0(run, 0, &together[0]), t1(run, 1, &together[1]);
  t0.join();
  t1.join();
  for (int i = 0; i < 2; ++i) {
    EXPECT_FALSE(alone[i].empty());
    EXPECT_EQ(together[i], alone[i]) << (i ? "RePOT" : "POT");
  }
}

TEST(CApiMapper, HandlesMayBeDestroyedInAnyOrder) {
  potmap_context* ctx = nullptr;
  POTMAP_ASSERT_OK(potmap_context_create(nullptr, &ctx));
  const Source& src = source();
  // A dictionary of its own, destroyed before the mapper that uses it.
  potmap_dictionary* dict = nullptr;
  POTMAP_ASSERT_OK(
      potmap_dictionary_build(src.list.data(), src.list.size(), src.map, nullptr, &dict));
  const potmap_mapper_options o = fast_options(0);
  potmap_mapper* m = nullptr;
  POTMAP_ASSERT_OK(potmap_mapper_create(ctx, dict, &o, &m));
  POTMAP_ASSERT_OK(potmap_dictionary_destroy(dict));
  POTMAP_ASSERT_OK(potmap_context_destroy(ctx));
  const RoomScan target = targets(1)[0];  // owns the arrays the description points to
  const potmap_scan s = target.scan();
  POTMAP_ASSERT_OK(potmap_mapper_add_scan(m, &s, nullptr));
  potmap_map* overall = nullptr;
  POTMAP_ASSERT_OK(potmap_mapper_overall_map(m, &overall));
  POTMAP_ASSERT_OK(potmap_mapper_destroy(m));
  int dim = 0;
  size_t n = 0;
  POTMAP_ASSERT_OK(potmap_map_size(overall, &dim, &n));  // the copy outlives its mapper
  EXPECT_GT(n, 0u);
  POTMAP_ASSERT_OK(potmap_map_destroy(overall));
}

#if defined(__SANITIZE_ADDRESS__)
#define POTMAP_TEST_ASAN 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define POTMAP_TEST_ASAN 1
#endif
#endif

TEST(CApiMapper, UseAfterDestroyIsDetected) {
#ifdef POTMAP_TEST_ASAN
  GTEST_FLAG_SET(death_test_style, "threadsafe");
  EXPECT_DEATH(
      {
        const potmap_mapper_options o = fast_options(0);
        potmap_mapper* m = nullptr;
        potmap_mapper_create(shared_context(), source().dict, &o, &m);
        potmap_mapper_destroy(m);
        potmap_mapper_reset(m);
      },
      "heap-use-after-free");
#else
  // Best effort, as for maps: the tag is cleared on destroy and nothing is allocated between.
  const potmap_mapper_options o = fast_options(0);
  potmap_mapper* m = nullptr;
  POTMAP_ASSERT_OK(potmap_mapper_create(shared_context(), source().dict, &o, &m));
  POTMAP_ASSERT_OK(potmap_mapper_destroy(m));
  POTMAP_EXPECT_FAIL(potmap_mapper_reset(m), POTMAP_ERROR_INVALID_HANDLE);
  EXPECT_TRUE(contains(potmap_last_error(), "destroyed")) << potmap_last_error();
  const Source& src = source();
  potmap_dictionary* d = nullptr;
  POTMAP_ASSERT_OK(potmap_dictionary_build(src.list.data(), src.list.size(), src.map, nullptr, &d));
  POTMAP_ASSERT_OK(potmap_dictionary_destroy(d));
  size_t atoms = 0;
  POTMAP_EXPECT_FAIL(potmap_dictionary_info(d, nullptr, &atoms, nullptr, nullptr, nullptr, nullptr),
                     POTMAP_ERROR_INVALID_HANDLE);
  POTMAP_EXPECT_FAIL(potmap_dictionary_destroy(d), POTMAP_ERROR_INVALID_HANDLE);
#endif
}

// A mapper saved after two scans and loaded into a new one maps the rest to the same overall map,
// bit for bit, as a mapper that never stopped; a file that is not a state, or a state of other
// options, is POTMAP_ERROR_INPUT naming the file, and leaves the mapper as it was.
TEST(CApiMapper, SavedStateContinuesBitForBit) {
  const Source& src = source();
  const std::vector<RoomScan> tgt = targets(4);
  const std::string dir = temp_dir("capi-mapper-state");
  for (int refine = 0; refine <= 1; ++refine) {
    SCOPED_TRACE(refine ? "RePOT" : "POT");
    const potmap_mapper_options o = fast_options(refine);
    potmap_mapper *whole = nullptr, *first = nullptr, *resumed = nullptr;
    POTMAP_ASSERT_OK(potmap_mapper_create(shared_context(), src.dict, &o, &whole));
    POTMAP_ASSERT_OK(potmap_mapper_create(shared_context(), src.dict, &o, &first));
    POTMAP_ASSERT_OK(potmap_mapper_create(shared_context(), src.dict, &o, &resumed));
    for (std::size_t i = 0; i < tgt.size(); ++i) {
      const potmap_scan s = tgt[i].scan();
      POTMAP_ASSERT_OK(potmap_mapper_add_scan(whole, &s, nullptr));
      if (i < 2) POTMAP_ASSERT_OK(potmap_mapper_add_scan(first, &s, nullptr));
    }
    const std::string path = dir + "/mapper.state";
    POTMAP_ASSERT_OK(potmap_mapper_save_state(first, path.c_str()));
    POTMAP_ASSERT_OK(potmap_mapper_load_state(resumed, path.c_str()));
    for (std::size_t i = 2; i < tgt.size(); ++i) {
      const potmap_scan s = tgt[i].scan();
      potmap_scan_stats st;
      st.struct_size = sizeof st;
      POTMAP_ASSERT_OK(potmap_mapper_add_scan(resumed, &s, &st));
      EXPECT_EQ(st.scan_index, i);  // the scan count came back
    }
    potmap_map *a = nullptr, *b = nullptr;
    POTMAP_ASSERT_OK(potmap_mapper_overall_map(whole, &a));
    POTMAP_ASSERT_OK(potmap_mapper_overall_map(resumed, &b));
    const potmap::KernelMap ka = read_back(a), kb = read_back(b);
    EXPECT_GT(ka.size(), 0u);
    EXPECT_EQ(ka.position, kb.position);
    EXPECT_EQ(ka.gamma, kb.gamma);
    EXPECT_EQ(ka.w_mean, kb.w_mean);
    EXPECT_EQ(ka.w_var, kb.w_var);
    POTMAP_ASSERT_OK(potmap_map_destroy(a));
    POTMAP_ASSERT_OK(potmap_map_destroy(b));

    // Refusals: another kind of file, a truncated state, other options; `first` unchanged.
    write_text(dir + "/not.state", "hello");
    EXPECT_EQ(potmap_mapper_load_state(first, (dir + "/not.state").c_str()), POTMAP_ERROR_INPUT);
    EXPECT_TRUE(contains(potmap_last_error(), "not.state")) << potmap_last_error();
    EXPECT_EQ(potmap_mapper_load_state(first, (dir + "/none.state").c_str()), POTMAP_ERROR_INPUT);
    potmap_mapper_options other = o;
    other.seed = 6;
    potmap_mapper* elsewise = nullptr;
    POTMAP_ASSERT_OK(potmap_mapper_create(shared_context(), src.dict, &other, &elsewise));
    EXPECT_EQ(potmap_mapper_load_state(elsewise, path.c_str()), POTMAP_ERROR_INPUT);
    EXPECT_TRUE(contains(potmap_last_error(), "options")) << potmap_last_error();
    EXPECT_EQ(potmap_mapper_load_state(first, nullptr), POTMAP_ERROR_NULL_ARGUMENT);
    write_text(dir + "/a-file", "x");  // no folder can be made under it
    EXPECT_EQ(potmap_mapper_save_state(first, (dir + "/a-file/dir/x.state").c_str()),
              POTMAP_ERROR_IO);
    const potmap_scan s = tgt[2].scan();
    potmap_scan_stats st;
    st.struct_size = sizeof st;
    POTMAP_ASSERT_OK(potmap_mapper_add_scan(first, &s, &st));
    EXPECT_EQ(st.scan_index, 2u);
    for (potmap_mapper* m : {whole, first, resumed, elsewise})
      POTMAP_ASSERT_OK(potmap_mapper_destroy(m));
  }
}

// Two C mappers of two parts of a path save RePOT's persistent maps with their information form;
// potmap_merge_maps fuses them as the C++ library fuses the C++ mappers' learners. POT's overall
// map has no such form and is refused.
TEST(CApiMapper, PersistentMapsSavedAndMerged) {
  const Source& src = source();
  const auto dict = cpp_dictionary(src);
  const potmap_mapper_options o = fast_options(1);
  potmap_mapper *a = nullptr, *b = nullptr, *pot = nullptr;
  POTMAP_ASSERT_OK(potmap_mapper_create(shared_context(), src.dict, &o, &a));
  POTMAP_ASSERT_OK(potmap_mapper_create(shared_context(), src.dict, &o, &b));
  const potmap_mapper_options po = fast_options(0);
  POTMAP_ASSERT_OK(potmap_mapper_create(shared_context(), src.dict, &po, &pot));
  potmap::Mapper ca(&cpp_context(), dict, cpp_options(1)), cb(&cpp_context(), dict, cpp_options(1));
  const std::vector<RoomScan> path = targets(4);
  for (std::size_t i = 0; i < path.size(); ++i) {
    const potmap_scan s = path[i].scan();
    POTMAP_ASSERT_OK(potmap_mapper_add_scan(i < 2 ? a : b, &s, nullptr));
    (i < 2 ? ca : cb).add_scan(to_cpp(path[i]));
    if (i == 0) POTMAP_ASSERT_OK(potmap_mapper_add_scan(pot, &s, nullptr));
  }
  const std::string dir = temp_dir("capi-mapper-merge");
  const std::string pa = dir + "/a.potmap", pb = dir + "/b.potmap", pc = dir + "/c.potmap";
  const std::string pp = dir + "/pot.potmap";
  POTMAP_ASSERT_OK(potmap_mapper_save_overall_map(a, pa.c_str()));
  POTMAP_ASSERT_OK(potmap_mapper_save_overall_map(b, pb.c_str()));
  POTMAP_ASSERT_OK(potmap_mapper_save_overall_map(pot, pp.c_str()));
  const char* ab[] = {pa.c_str(), pb.c_str()};
  POTMAP_ASSERT_OK(potmap_merge_maps(ab, 2, pc.c_str(), 0));
  potmap_map* c = nullptr;
  POTMAP_ASSERT_OK(potmap_map_load(pc.c_str(), &c));
  const potmap::JointBhm fused =
      potmap::merge_joint_bhm({&ca.repot()->learner(), &cb.repot()->learner()});
  expect_same(read_back(c), fused.map(), "merged map");
  const char* ap[] = {pa.c_str(), pp.c_str()};
  POTMAP_EXPECT_FAIL(potmap_merge_maps(ap, 2, pc.c_str(), 0), POTMAP_ERROR_INPUT);
  EXPECT_TRUE(contains(potmap_last_error(), "pot.potmap: written without its information form"))
      << potmap_last_error();
  POTMAP_EXPECT_FAIL(potmap_mapper_save_overall_map(a, nullptr), POTMAP_ERROR_NULL_ARGUMENT);
  potmap_map_destroy(c);
  for (potmap_mapper* m : {a, b, pot}) potmap_mapper_destroy(m);
}
