#pragma once
// The (sample, kernel) pair lists of the BHM and ABHM device paths, uploaded once per call.

#include <boost/compute/buffer.hpp>
#include <string>

#include "bhm_detail.hpp"
#include "runtime/device_buffers.hpp"

namespace potmap::detail {

struct PairBuffers {
  boost::compute::buffer sample_start, sample_kernels, kernel_start, kernel_samples;
};

/// `pairs` on ctx's device; `who` names the learner in an allocation error ("BHM", "ABHM").
inline PairBuffers upload_pairs(Context& ctx, const SampleKernelPairs& pairs,
                                const std::string& who) {
  return {to_device(ctx, pairs.sample_start, (who + ": sample pair starts").c_str()),
          to_device(ctx, pairs.sample_kernels, (who + ": sample pair kernels").c_str()),
          to_device(ctx, pairs.kernel_start, (who + ": kernel pair starts").c_str()),
          to_device(ctx, pairs.kernel_samples, (who + ": kernel pair samples").c_str())};
}

}  // namespace potmap::detail
