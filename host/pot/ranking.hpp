#pragma once
// The ranking stage of a transfer (eq. 6, 7): which (atom, rotation) each target sector gets.
// Assembly runs in prepare_transfer() (host, may overlap the device), the solves and the choice
// in finish_transfer(). Two modes (PotRanking): exhaustive and indexed (coarse to fine).
#include <functional>
#include <vector>

#include "potmap/ot/sinkhorn.hpp"
#include "potmap/pot/transfer.hpp"

namespace potmap::detail {

/// What the ranking chose for one sector.
struct Winner {
  long atom = -1;  ///< -1: no candidate
  double angle = 0;
  double score = 0;
  bool converged = false;  ///< the winner's ranking problems converged
};

/// Solves a batch on the device, or one problem at a time on the CPU reference (ctx null).
std::vector<SinkhornResult> solve(Context* ctx, const SinkhornBatch& batch,
                                  const SinkhornOptions& opt);

/// solve() started: on the device, in flight until wait(); with ctx null, the CPU reference
/// runs in wait(). `batch` must outlive it.
class PendingSolve {
 public:
  PendingSolve(Context* ctx, const SinkhornBatch& batch, const SinkhornOptions& opt);
  std::vector<SinkhornResult> wait();

 private:
  const SinkhornBatch& batch_;
  SinkhornRun run_;
  bool on_device_;
};

/// Fills pt.candidates and pt.ranking for pt.sectors (exhaustive or indexed, by options). The
/// indexed ranking's sectors are assembled on ctx's host team (ctx null: this thread); host
/// only, the device is not used.
void assemble_ranking(Context* ctx, const Dictionary& dict, const PotOptions& options,
                      const std::vector<long>& warm_atoms, PreparedTransfer& pt);

/// Solves the prepared ranking and returns the winner of every sector. Adds the solves' time to
/// timing.ranking_ms and the host work between them to timing.prepare_ms. `beside`, if given,
/// runs on this thread once while the first ranking launch is on the device (host work that
/// does not depend on the winners); its time is within ranking_ms.
std::vector<Winner> rank_sectors(Context* ctx, const Dictionary& dict, const PreparedTransfer& pt,
                                 const PotOptions& options, PotTiming& timing,
                                 const std::function<void()>& beside = {});

}  // namespace potmap::detail
