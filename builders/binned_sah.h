#pragma once
/// Binned SAH builder: "On fast Construction of SAH-based Bounding Volume Hierarchies", I. Wald, 2007.
/// Primitives are binned by centroid into `bins` equal intervals of the node's centroid bounds on each
/// axis; the best of the bins - 1 planes per axis, or of the size splits (size_split.h), is chosen by the
/// SAH.

#include <cstdint>

#include "builders/top_down.h"
#include "core/build_input.h"

namespace sahbench {

struct BinnedSahParams {
  uint32_t bins = 32;  ///< Wald 2007 finds 16 to 32 bins within a few percent of a full sweep
  /// Use fewer bins on small nodes: min(bins, 4 + n / 20) for n primitives, Embree's rule
  /// (kernels/builders/heuristic_binning.h). Small nodes are most nodes, and resetting and sweeping
  /// 32 bins per axis for a handful of primitives is most of the build time; off gives textbook binning.
  bool adaptive_bins = true;
  TopDownConfig top_down;
};

/// Bins used for a node of `prim_count` primitives.
uint32_t bins_for_node(const BinnedSahParams& params, uint32_t prim_count);

inline constexpr uint32_t kMinBins = 4;
inline constexpr uint32_t kMaxBins = 256;

Bvh build_binned_sah(const BuildInput& input, const BinnedSahParams& params);

/// The best binned split of primitives [begin, end) of `input`, by the same code the builder uses.
/// Exposed so tests can compare split searches node by node.
Split find_binned_split(const BuildInput& input, std::span<const uint32_t> prims,
                        const BinnedSahParams& params);

}  // namespace sahbench
