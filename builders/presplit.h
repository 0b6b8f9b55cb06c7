#pragma once
/// Presplitting: large triangles' references are split before a binned SAH build, so that the build sees
/// several tight boxes where one loose box would overlap its neighbours. After the triangle splitting of
/// "Fast Parallel Construction of High-Quality Bounding Volume Hierarchies", T. Karras and T. Aila, HPG
/// 2013, section 5: each triangle gets a share of a global budget of extra references in proportion to a
/// priority, (2^-l (A_box - A_ideal))^(1/3), where A_box - A_ideal is the area its box wastes over the
/// boxes of infinitely fine pieces and l the level of the coarsest plane of a dyadic grid over the scene
/// that cuts its box (triangles across the planes that top-level splits use matter most); then each
/// triangle is cut recursively at the coarsest grid plane through its current piece, the remaining splits
/// shared between the two halves by the area they waste. Pieces are clipped polygons in double precision
/// (core/clip_polygon.h), bounded by boxes rounded outward, so the leaves holding a triangle's pieces
/// cover it.
///
/// The pieces are then built by the binned SAH builder (builders/binned_sah.h) as PrimRefs of their
/// triangle; leaves refer to triangle indices, and a leaf holding several pieces of one triangle keeps
/// one reference. The tree holds at most floor((1 + split_budget) n) references.

#include <cstdint>

#include "builders/binned_sah.h"
#include "core/build_input.h"

namespace sahbench {

/// Largest split budget accepted: four extra references per triangle on average.
inline constexpr float kPresplitMaxBudget = 4.0f;

struct PresplitParams {
  /// Extra references as a fraction of the triangles: the pieces number at most (1 + split_budget) n.
  /// 0.3, Karras and Aila's own budget: of 0.05 to 1 it gave Sponza (the tuning scene with large
  /// triangles) its lowest SAH, 2% below no splits; the tuning scenes of uniform small triangles (the
  /// terrain, the bunny) lose 1-3% to any budget, and a few splits alone (0.01-0.05) cost Sponza 10-20%.
  float split_budget = 0.3f;
  /// The binned build of the pieces, without size splits (builders/size_split.h): the split pieces are
  /// what large triangles become, and on tune.toml's Sponza view size splits too traced its shadow rays
  /// slower after the collapse.
  BinnedSahParams binned{.top_down = {.size_split = false}};
};

/// Builds over `input`, whose `triangles` must be given (splitting clips them).
Bvh build_presplit(const BuildInput& input, const PresplitParams& params);

/// Rejects parameters out of range; the message names the parameter and its value.
void check_presplit_params(const PresplitParams& params);

}  // namespace sahbench
