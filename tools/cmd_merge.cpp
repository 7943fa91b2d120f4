// `potmap merge A.potmap B.potmap ... -o C.potmap`: joint BHM maps of overlapping places, each
// learned from its own data, fused in information form (include/potmap/learn/bhm_joint_merge.hpp).
#include <cctype>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <optional>

#include "commands.hpp"
#include "potmap/error.hpp"
#include "potmap/io/map_io.hpp"
#include "potmap/learn/bhm_joint_merge.hpp"

namespace potmap::cli {

namespace {

struct MergeArgs {
  std::vector<std::string> maps;
  std::string out;
  bool allow_overlap = false;
};

JointBhm read_mergeable(const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  if (ext != ".potmap")
    throw InputError(path + ": a '" + ext +
                     "' map holds means and variances only: written without its information "
                     "form, it cannot be merged exactly");
  std::optional<JointBhm> m = read_joint_bhm_information(path);
  if (!m)
    throw InputError(path +
                     ": written without its information form (a map of POT's averaged maps, "
                     "ABHM, or a build before merging): it cannot be merged exactly");
  return std::move(*m);
}

int run_merge(const MergeArgs& a) {
  if (a.maps.size() < 2)
    throw ArgumentError("merge: give at least two maps, got " + std::to_string(a.maps.size()));
  const auto t0 = std::chrono::steady_clock::now();
  std::vector<JointBhm> maps;
  maps.reserve(a.maps.size());
  for (const std::string& p : a.maps) {
    maps.push_back(read_mergeable(p));
    std::printf("input          %s: %zu kernels, %zu scans\n", p.c_str(), maps.back().size(),
                maps.back().data_ids().size());
  }
  std::vector<const JointBhm*> ptrs;
  for (const JointBhm& m : maps) ptrs.push_back(&m);
  JointBhmMergeOptions o;
  o.allow_overlap = a.allow_overlap;
  o.names = a.maps;
  const JointBhm c = merge_joint_bhm(ptrs, o);
  const KernelMap exported = c.map();
  write_joint_bhm_map(c, a.out, &exported);
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::printf(
      "merged         %zu kernels, %zu scans; means solved in %zu CG iterations, "
      "relative residual %.1e\n",
      c.size(), c.data_ids().size(), c.last_stats().cg_iterations, c.last_stats().residual);
  std::printf("wrote          %s (%.2f s)\n", a.out.c_str(), seconds);
  return 0;
}

}  // namespace

void write_learned_map(const JointBhm* learner, const KernelMap& map, const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  if (learner && ext == ".potmap")
    write_joint_bhm_map(*learner, path, &map);
  else
    write_map(map, path);
}

void register_merge(CLI::App& app, Runner& runner) {
  CLI::App* cmd = app.add_subcommand(
      "merge",
      "Fuse joint BHM maps of overlapping places (RePOT's `potmap mapping` maps, BHM drives) "
      "in information form: precisions and information vectors added, the prior counted once, "
      "the means solved again (docs/merging.md). Maps must share the kernel lattice and prior; "
      "maps of the same scans are refused");
  auto a = std::make_shared<MergeArgs>();
  cmd->add_option("MAPS", a->maps, ".potmap maps written with their information form")
      ->required()
      ->check(CLI::ExistingFile);
  cmd->add_option("-o,--out", a->out, "Merged map to write (.potmap, with its information form)")
      ->required();
  cmd->add_flag("--allow-overlap", a->allow_overlap,
                "Merge maps that learned the same scans (those scans then count twice)");
  cmd->callback([&runner, a] { runner.action = [a] { return run_merge(*a); }; });
}

}  // namespace potmap::cli
