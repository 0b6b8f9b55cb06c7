#include "builders/binned_sah.h"

#include <string>
#include <vector>

#include "builders/binned_splitter.h"
#include "core/error.h"

namespace sahbench {
namespace {

void check_bins(uint32_t bins) {
  if (bins < kMinBins || bins > kMaxBins)
    throw Error("binned_sah: bins = " + std::to_string(bins) + " is outside [" + std::to_string(kMinBins) +
                ", " + std::to_string(kMaxBins) + "]");
}

}  // namespace

Bvh build_binned_sah(const BuildInput& input, const BinnedSahParams& params) {
  check_bins(params.bins);
  check_config(params.top_down, "binned_sah");
  check_prim_count(input.size(), "binned_sah");
  PrimRefArray refs(input.size());
  const NodeRange root = make_prim_refs(input, refs.span());
  BinnedSplitter splitter(refs.span(), params);
  return build_top_down(splitter, params.top_down, root);
}

Split find_binned_split(const BuildInput& input, std::span<const uint32_t> prims,
                        const BinnedSahParams& params) {
  check_bins(params.bins);
  std::vector<PrimRef> refs;
  refs.reserve(prims.size());
  for (uint32_t p : prims) refs.push_back({input.bounds[p], p, 0});
  BinnedSplitter splitter(refs, params);
  return splitter.find_split(bounds_of(refs, 0, static_cast<uint32_t>(refs.size())));
}

}  // namespace sahbench
