#pragma once
/// SBVH: "Spatial Splits in Bounding Volume Hierarchies", M. Stich, H. Friedrich and A. Dietrich, HPG 2009.
/// At each node the best object split (binned SAH on the references' box centres, as binned_sah) competes
/// with the best spatial split: the node's box is cut into equal slabs on each axis, each reference's
/// triangle is clipped to the slabs it spans, and a plane between slabs may then cut a triangle into two
/// references, each bounded by its own part (section 4.2). Spatial splits are tried only where the object
/// split's children overlap by more than alpha times the root's area (section 4.3; by default also by a
/// tenth of the node's own area, as in Embree's spatial-split builder), and a reference the
/// chosen plane cuts stays whole on one side where the SAH prefers that (reference unsplitting, 4.4).
///
/// References are PrimRefs whose boxes bound clipped parts, so leaf boxes may be smaller than their
/// triangles' boxes; the tree holds at most (1 + max_dup) n references. Runs on the shared top-down
/// recursion (top_down.h): every node owns spare reference positions, and each partition hands the
/// spare left after its own duplicates to its children in proportion to their sizes, as Embree's
/// spatial-split builder does. The tree is the same for any thread count.

#include <cstdint>
#include <string_view>

#include "builders/binned_sah.h"
#include "builders/top_down.h"
#include "core/build_input.h"

namespace sahbench {

struct SbvhParams {
  uint32_t bins = 32;  ///< object-split bins per axis, as binned_sah
  /// Spatial-split slabs per axis. 16 as in Embree's spatial-split builder (SPATIAL_BINS in
  /// kernels/builders/heuristic_spatial_array.h): on Sponza 16 slabs built 16% faster than 32, traced 1-3%
  /// faster, and cost 1% more SAH (65.45 against 64.71, still below Embree high's 65.64).
  uint32_t spatial_bins = 16;
  /// min(bins, 4 + n / 20) object bins and min(spatial_bins, 4 + n / 20) slabs on a node of n references
  /// (binned_sah's rule for small nodes).
  bool adaptive_bins = true;
  /// Spatial splits are tried where the best object split's children overlap by an area above alpha
  /// times the root's (Stich et al. 2009, section 4.3, who use 1e-5); 1 turns spatial splits off.
  float alpha = 1e-5f;
  /// ... and by at least node_overlap times the node's own area: Embree's second condition
  /// (SPATIAL_ASPLIT_OVERLAP_THRESHOLD = 0.1 in kernels/builders/heuristic_spatial_array.h). On Sponza
  /// it skips about half the spatial searches at no cost in SAH; 0 leaves Stich et al.'s rule alone.
  float node_overlap = 0.1f;
  /// The tree holds at most floor((1 + max_dup) n) references. Stich et al. report 1.1 to 1.5 references
  /// per primitive; Embree allows 1.2 (max_spatial_split_replications). With 0.3 the needles (100K long
  /// thin triangles) ran out of budget at 1.21 references and traced 8-16% faster than binned SAH; with 0.5
  /// they take 1.48 and trace 16-33% faster (four runs). Scenes that need fewer references take few more
  /// (Sponza 1.14 -> 1.18, its rays/second the same), and the build costs 8% more on Sponza.
  float max_dup = 0.5f;
  bool unsplit = true;  ///< reference unsplitting (section 4.4)
  /// Size splits off (builders/size_split.h): spatial splits already take large triangles apart by
  /// clipping their references, and the two together made the collapse over sbvh test more triangles per
  /// ray on Sponza, though its SAH was lower (72a5422).
  TopDownConfig top_down{.size_split = false};
};

inline constexpr float kSbvhMaxDup = 4.0f;

/// Builds an SBVH of `input`, whose `triangles` must be given (the clipping needs them). Errors name
/// `builder`, the registered builder that asked for the tree.
Bvh build_sbvh(const BuildInput& input, const SbvhParams& params, std::string_view builder);

/// Rejects parameters out of range or inconsistent; the message names the builder, parameter and value.
void check_sbvh_params(const SbvhParams& params, std::string_view builder);

}  // namespace sahbench
