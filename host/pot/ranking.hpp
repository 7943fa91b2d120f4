#pragma once
// The ranking stage of a transfer (eq. 6, 7): which (atom, rotation) each target sector gets.
// Assembly runs in prepare_transfer() (host, may overlap the device), the solves and the choice
// in finish_transfer(). Two modes (PotRanking): exhaustive and indexed (coarse to fine).
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

/// Fills pt.candidates and pt.ranking for pt.sectors (exhaustive or indexed, by options). The
/// indexed ranking's sectors are assembled on ctx's host team (ctx null: this thread); host
/// only, the device is not used.
void assemble_ranking(Context* ctx, const Dictionary& dict, const PotOptions& options,
                      const std::vector<long>& warm_atoms, PreparedTransfer& pt);

/// Solves the prepared ranking and returns the winner of every sector. Adds the solves' time to
/// timing.ranking_ms and the host work between them to timing.prepare_ms.
std::vector<Winner> rank_sectors(Context* ctx, const Dictionary& dict, const PreparedTransfer& pt,
                                 const PotOptions& options, PotTiming& timing);

}  // namespace potmap::detail
