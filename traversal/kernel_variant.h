#pragma once
// Which ray/triangle test, ray/box test and instruction set a traversal kernel uses. Layouts are
// compiled for one variant, and the harness writes the variant into every CSV row, so the error of a
// faster, less exact variant can be reported beside its speed (DESIGN.md, numerical policy).

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

namespace sahbench {

enum class TriangleTestKind : uint8_t {
  kWatertight,               ///< Woop et al. 2013 (triangle_tests.h), the default
  kMollerTrumbore,           ///< Möller and Trumbore 1997 with its epsilon of 1e-6
  kMollerTrumboreNoEpsilon,  ///< the same with epsilon 0: only det == 0 is rejected
  /// Möller–Trumbore in the form of Embree's Triangle4 test, the geometric normal stored with the
  /// triangle and the division left for hits (MollerTrumboreNormalTest, triangle_tests.h)
  kMollerTrumboreNormal,
};

enum class BoxTestKind : uint8_t {
  kRobust,  ///< Ize 2013's conservative slab test (ray_box.h), the default
  kFast,    ///< the plain slab test
  kFma,     ///< the plain slab test in Embree's form: one fused multiply-subtract per plane (ray_box.h)
};

/// The order in which any hit (shadow rays) visits the children a ray enters; closest hit always visits
/// them nearest first.
enum class AnyHitOrder : uint8_t {
  kAuto,     ///< kStored on wide trees (arity above 2), kNearest on binary ones (bvh2_traversal.h)
  kNearest,  ///< nearest entry distance first, as closest hit
  kStored,   ///< the tree's child order (the wide builders store an occlusion order: builders/child_order.h)
  /// The nearest child entered first (ties to the earlier slot, the tree's choice), then the others in
  /// the tree's order: the first step of nearest first without its sort, and the occlusion order for the
  /// rest.
  kNearestStored,
  /// The farthest child entered first (ties to the earlier slot), then the others in the tree's order:
  /// for shadow rays whose occluders lie near the light rather than near the surface they leave, such
  /// as a light inside a fixture or under a dome.
  kFarthestStored,
};

/// The instruction set a SIMD kernel is compiled for. kAuto picks the widest one that is both compiled
/// in and supported by the CPU running the program.
enum class KernelIsa : uint8_t { kAuto, kScalar, kSse, kAvx2, kAvx512 };

struct KernelVariant {
  TriangleTestKind triangle = TriangleTestKind::kWatertight;
  BoxTestKind box = BoxTestKind::kRobust;
  AnyHitOrder any_hit = AnyHitOrder::kAuto;

  friend constexpr bool operator==(const KernelVariant&, const KernelVariant&) = default;
};

std::string_view to_string(TriangleTestKind kind);
std::string_view to_string(BoxTestKind kind);
std::string_view to_string(KernelIsa isa);
std::string_view to_string(AnyHitOrder order);
/// The inverse of to_string; nullopt for an unknown name.
std::optional<TriangleTestKind> parse_triangle_test(std::string_view name);
std::optional<BoxTestKind> parse_box_test(std::string_view name);
std::optional<KernelIsa> parse_kernel_isa(std::string_view name);
std::optional<AnyHitOrder> parse_any_hit_order(std::string_view name);
/// Every any-hit order's name, auto first, joined by `separator`: for help and error messages.
std::string any_hit_order_names(std::string_view separator);

/// Whether the CPU (and OS) can run code for `isa`, whether or not this program compiled kernels for it:
/// tells an ISA the CPU lacks from one the build left out. kScalar always; kAuto never.
bool cpu_supports_kernel_isa(KernelIsa isa);
/// Whether kernels for `isa` are compiled into this program and the CPU (and OS) can run them. kScalar
/// is always available; kAuto is never (resolve it first).
bool kernel_isa_available(KernelIsa isa);
/// The widest available of kAvx512, kAvx2, kSse, kScalar, never above `widest` (kAuto: no limit).
KernelIsa best_kernel_isa(KernelIsa widest = KernelIsa::kAuto);
/// What isa=auto runs: the best available, AVX-512 included, on Intel and AMD CPUs alike. The wide
/// kernels use 128- and 256-bit vectors only, so their AVX-512 build is the same code in EVEX encodings,
/// with 32 vector registers and mask registers for the compares. It traced faster than the AVX2 build in
/// the median cell, and never more than 2% slower where the difference was measurable, on an Intel Xeon
/// (family 6, model 207) and an AMD EPYC Zen 4 (family 25, model 17; its 512-bit units are split in two,
/// but 256-bit EVEX code runs at full rate). isa=avx2 and isa=avx512 select either. The README's table
/// lists the choice by CPU family, with the measurements.
KernelIsa preferred_kernel_isa();

}  // namespace sahbench
