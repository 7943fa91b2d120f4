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
#include "potmap/mapping/map_files.hpp"

namespace potmap::cli {

namespace {

struct MergeArgs {
  std::vector<std::string> maps;
  std::string out;
  bool allow_overlap = false;
};

// A map file's mergeable form: a joint BHM's information form or POT's averaged map's sums.
struct Mergeable {
  std::optional<JointBhm> joint;
  std::optional<AveragedMap> averaged;
};

Mergeable read_mergeable(const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  if (ext != ".potmap")
    throw InputError(path + ": a '" + ext +
                     "' map holds means and variances only: written without its information "
                     "form, it cannot be merged exactly");
  Mergeable m;
  m.joint = read_joint_bhm_information(path);
  if (!m.joint) m.averaged = read_averaged_map_information(path);
  if (!m.joint && !m.averaged)
    throw InputError(path +
                     ": written without its information form (a map of ABHM, of POT's summed "
                     "kernels, a .csv or .npz, or a build before merging): it cannot be merged "
                     "exactly");
  return m;
}

int merge_joint(const MergeArgs& a, std::vector<Mergeable>& in) {
  std::vector<const JointBhm*> ptrs;
  for (const Mergeable& m : in) ptrs.push_back(&*m.joint);
  JointBhmMergeOptions o;
  o.allow_overlap = a.allow_overlap;
  o.names = a.maps;
  const JointBhm c = merge_joint_bhm(ptrs, o);
  const KernelMap exported = c.map();
  write_joint_bhm_map(c, a.out, &exported);
  std::printf(
      "merged         %zu kernels, %zu scans; means solved in %zu CG iterations, "
      "relative residual %.1e\n",
      c.size(), c.data_ids().size(), c.last_stats().cg_iterations, c.last_stats().residual);
  return 0;
}

int merge_averaged(const MergeArgs& a, std::vector<Mergeable>& in) {
  AveragedMap c = std::move(*in[0].averaged);
  for (std::size_t i = 1; i < in.size(); ++i) c.add_map(*in[i].averaged);
  write_averaged_map(c, a.out);
  std::printf(
      "merged         %zu anchors (POT's averaged maps: anchor sums added, weights "
      "solved again)\n",
      c.size());
  return 0;
}

int run_merge(const MergeArgs& a) {
  if (a.maps.size() < 2)
    throw ArgumentError("merge: give at least two maps, got " + std::to_string(a.maps.size()));
  const auto t0 = std::chrono::steady_clock::now();
  std::vector<Mergeable> in;
  for (const std::string& p : a.maps) {
    in.push_back(read_mergeable(p));
    const Mergeable& m = in.back();
    if (m.joint)
      std::printf("input          %s: joint BHM, %zu kernels, %zu scans\n", p.c_str(),
                  m.joint->size(), m.joint->data_ids().size());
    else
      std::printf("input          %s: POT averaged map, %zu anchors\n", p.c_str(),
                  m.averaged->size());
    if (m.joint.has_value() != in.front().joint.has_value())
      throw ArgumentError("merge: " + a.maps.front() + " is " +
                          (in.front().joint ? "a joint BHM map" : "POT's averaged map") + ", " + p +
                          " " + (m.joint ? "a joint BHM map" : "POT's averaged map") +
                          ": maps of one kind merge");
  }
  const int rc = in.front().joint ? merge_joint(a, in) : merge_averaged(a, in);
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::printf("wrote          %s (%.2f s)\n", a.out.c_str(), seconds);
  return rc;
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
      "Fuse maps of overlapping places: joint BHM maps (RePOT's `potmap mapping` maps, BHM "
      "drives) exactly in information form (precisions and information vectors added, the "
      "prior counted once, the means solved again; maps must share the kernel lattice and "
      "prior; maps of the same scans are refused); POT's averaged maps by adding their anchors' "
      "sums (docs/merging.md)");
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
