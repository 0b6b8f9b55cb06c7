#pragma once
// Layouts: traversal-specific packings compiled from a common-format Bvh (DESIGN.md). A layout owns
// its compiled data and its kernels; the harness times compile() separately from the build, and
// trace_*() separately from everything else. Kernels are selected at compile time inside each layout;
// the harness calls through this interface once per batch of rays, never per ray or per node.

#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "core/bvh.h"
#include "core/ray.h"
#include "core/triangle.h"
#include "traversal/kernel_variant.h"

namespace sahbench {

/// Work counted by a layout's statistics kernel, summed over a batch of rays.
struct TraceCounts {
  uint64_t rays = 0;
  uint64_t nodes_visited = 0;  ///< nodes whose box test passed and whose children or primitives were examined
  uint64_t prims_tested = 0;   ///< ray/primitive tests
  uint64_t leaves_visited =
      0;  ///< of nodes_visited, the leaves (the rest are inner nodes, box-testing children)
};

class CompiledLayout {
 public:
  virtual ~CompiledLayout() = default;
  /// Closest hits of `rays` into `hits` (same size), in parallel with TBB under the caller's thread limit.
  virtual void trace_closest(std::span<const Ray> rays, std::span<Hit> hits) const = 0;
  /// Occlusion of `rays` into `occluded` (1 when any hit within [tmin, tmax]).
  virtual void trace_any(std::span<const Ray> rays, std::span<uint8_t> occluded) const = 0;
  /// The same traversals with counters; not timed.
  virtual TraceCounts count_closest(std::span<const Ray> rays) const = 0;
  virtual TraceCounts count_any(std::span<const Ray> rays) const = 0;
  /// The closest-hit counters of each ray on its own, into `counts` (same size), for per-pixel maps.
  /// The default calls count_closest on each single-ray span, in parallel with TBB; not timed.
  virtual void count_closest_per_ray(std::span<const Ray> rays, std::span<TraceCounts> counts) const;
  /// Exact bytes of the compiled structure (nodes, references, packed leaves).
  virtual std::size_t bytes() const = 0;
  /// Refit: takes the new positions of the triangles it was compiled over (same count and indices) and
  /// recomputes every box bottom up, keeping the topology. Layouts that borrow the triangles (bvh2)
  /// borrow the new ones too, which must then outlive the layout. Throws Error for another count.
  virtual void refit(std::span<const Triangle> triangles);
  /// The instruction set its kernels run with ("scalar", "sse", "avx2", "avx512"), for the CSV.
  virtual std::string isa() const { return "scalar"; }
};

/// A layout and its options, as a config or the CLI names it: `NAME[:key=value,...]` with the keys
///   tri = watertight | mt | mt0 | mtn   (triangle test; mt0 is Möller–Trumbore with epsilon 0, mtn
///                                        Möller–Trumbore with a stored normal, as Embree's Triangle4)
///   box = robust | fast | fma           (ray/box test)
///   isa = auto | scalar | sse | avx2 | avx512   (SIMD layouts, and the binary layouts' packets only;
///                                                auto: kernel_variant.h's preferred_kernel_isa: the
///                                                widest available)
///   packet = 1 | 8 | 16                 (rays traced one at a time, or 8 or 16 at a time by the packet
///                                        kernels of wide_packets.inl and, for the binary layouts,
///                                        pair_packets.inl: 8 with avx2 and avx512, 16 with avx512)
/// e.g. "bvh8", "bvh2:tri=mt,box=fast", "bvh8:isa=avx2", "bvh8:packet=8", "bvh2_packed:packet=16".
/// The largest packet of the packet kernels (layout option packet=16): ray chunks hold whole packets.
inline constexpr uint32_t kMaxWidePacket = 16;

struct LayoutSpec {
  std::string name;
  KernelVariant variant;
  KernelIsa isa = KernelIsa::kAuto;
  /// Rays per packet: 1 (single-ray kernels), 8 or 16.
  uint32_t packet = 1;
  /// The wide layouts' any-hit kernels, single-ray and packets: test first the leaf that blocked the last
  /// ray ending at the same point, a shadow cache (wide_kernels.inl: ShadowCache). `shadow_cache=off`
  /// measures the walk alone.
  bool shadow_cache = true;

  /// The canonical text: the name, then the options that differ from the defaults, in the order above.
  /// This is what the CSV's layout column holds, so "bvh2:tri=watertight" and "bvh2" are one cell.
  std::string text() const;
  bool operator==(const LayoutSpec&) const = default;
};

struct LayoutInfo {
  std::string name;
  std::string summary;
  /// The arity of the trees this layout is meant for; the harness pairs a builder only with the
  /// layouts of its arity (a layout may still compile narrower trees, e.g. in tests).
  uint32_t arity = 2;
  /// Whether the `isa` option picks every kernel's build (the SIMD layouts).
  bool has_isa = false;
  /// Whether the `packet` option applies: the SIMD layouts, and the binary ones, which take `isa` with
  /// it to pick their packet kernels' build (isa=auto's by default).
  bool has_packet = false;
};

std::span<const LayoutInfo> layouts();
/// The layout called `name`; an unknown name is an error listing the known ones.
const LayoutInfo& find_layout(std::string_view name);
/// Parses and checks a layout spec; an unknown layout, key or value is an error naming it.
LayoutSpec parse_layout_spec(std::string_view text);
/// Why this CPU and build cannot run `spec`, or nullopt: an instruction set it lacks (`isa=avx512` or
/// `packet=16` without AVX-512, `isa=avx2` or `packet=8` without AVX2, `isa=sse` without SSE 4.2). A run
/// skips such a layout, as it skips Embree's packets the CPU lacks. `widest` caps what the CPU is taken
/// to have (kAuto: no cap), so that a test can ask what a CPU without AVX-512 would do.
std::optional<std::string> layout_unavailable(const LayoutSpec& spec, KernelIsa widest = KernelIsa::kAuto);
/// The instruction set the kernels of `spec` run with (the SIMD layouts', and the binary layouts'
/// packet kernels'): `spec.isa`, or for kAuto the preferred one (preferred_kernel_isa), capped at
/// `widest` as for layout_unavailable.
KernelIsa layout_kernel_isa(const LayoutSpec& spec, KernelIsa widest = KernelIsa::kAuto);
/// Whether some CPU may lack what `spec` needs: packets, or an instruction set above scalar. Every CPU
/// runs the others (`isa=auto` falls back to what the CPU has).
bool layout_depends_on_cpu(const LayoutSpec& spec);
/// Compiles `bvh` over `triangles` (which must outlive the result) with the layout `spec` names. Throws
/// Error when the tree does not suit the layout (e.g. arity too large) or the ISA is not available,
/// naming both. The free functions above (the registry, the spec syntax, what this CPU runs) are in the
/// library sahbench_layout_spec, which builds without the kernels; compile_layout is in sahbench_traversal.
std::unique_ptr<CompiledLayout> compile_layout(const LayoutSpec& spec, const Bvh& bvh,
                                               std::span<const Triangle> triangles);
std::unique_ptr<CompiledLayout> compile_layout(std::string_view spec, const Bvh& bvh,
                                               std::span<const Triangle> triangles);

}  // namespace sahbench
