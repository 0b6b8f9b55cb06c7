#include "traversal/kernel_variant.h"

#include <array>
#include <utility>

namespace sahbench {
namespace {

constexpr std::array<std::pair<TriangleTestKind, std::string_view>, 4> kTriangleNames{{
    {TriangleTestKind::kWatertight, "watertight"},
    {TriangleTestKind::kMollerTrumbore, "mt"},
    {TriangleTestKind::kMollerTrumboreNoEpsilon, "mt0"},
    {TriangleTestKind::kMollerTrumboreNormal, "mtn"},
}};
constexpr std::array<std::pair<BoxTestKind, std::string_view>, 3> kBoxNames{{
    {BoxTestKind::kRobust, "robust"},
    {BoxTestKind::kFast, "fast"},
    {BoxTestKind::kFma, "fma"},
}};
constexpr std::array<std::pair<AnyHitOrder, std::string_view>, 5> kAnyHitOrderNames{{
    {AnyHitOrder::kAuto, "auto"},
    {AnyHitOrder::kNearest, "nearest"},
    {AnyHitOrder::kStored, "stored"},
    {AnyHitOrder::kNearestStored, "nearest_stored"},
    {AnyHitOrder::kFarthestStored, "farthest_stored"},
}};
constexpr std::array<std::pair<KernelIsa, std::string_view>, 5> kIsaNames{{
    {KernelIsa::kAuto, "auto"},
    {KernelIsa::kScalar, "scalar"},
    {KernelIsa::kSse, "sse"},
    {KernelIsa::kAvx2, "avx2"},
    {KernelIsa::kAvx512, "avx512"},
}};

template <class Enum, std::size_t N>
std::string_view name_of(const std::array<std::pair<Enum, std::string_view>, N>& names, Enum value) {
  for (const auto& [v, name] : names)
    if (v == value) return name;
  return "?";
}

template <class Enum, std::size_t N>
std::optional<Enum> value_of(const std::array<std::pair<Enum, std::string_view>, N>& names,
                             std::string_view name) {
  for (const auto& [v, n] : names)
    if (n == name) return v;
  return std::nullopt;
}

// What the CPU and the OS support. __builtin_cpu_supports (GCC and Clang) consults CPUID and, for AVX
// and AVX-512, XGETBV, so a feature the OS does not save across context switches reads as absent.
bool cpu_supports(KernelIsa isa) {
#if defined(__x86_64__) || defined(__i386__)
  switch (isa) {
    case KernelIsa::kScalar:
      return true;
    case KernelIsa::kSse:
      return __builtin_cpu_supports("sse4.2");
    // x86-64-v3, the level the AVX2 kernels are compiled for.
    case KernelIsa::kAvx2:
      return __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma") &&
             __builtin_cpu_supports("bmi2");
    // x86-64-v4: AVX-512 F, BW, CD, DQ and VL.
    case KernelIsa::kAvx512:
      return __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512bw") &&
             __builtin_cpu_supports("avx512cd") && __builtin_cpu_supports("avx512dq") &&
             __builtin_cpu_supports("avx512vl");
    case KernelIsa::kAuto:
      return false;
  }
  return false;
#else
  return isa == KernelIsa::kScalar;
#endif
}

// Which kernels traversal/CMakeLists.txt compiled in (it defines these when the target is x86-64).
bool compiled_in(KernelIsa isa) {
  switch (isa) {
    case KernelIsa::kScalar:
      return true;
#if defined(SAHBENCH_HAVE_X86_KERNELS)
    case KernelIsa::kSse:
    case KernelIsa::kAvx2:
    case KernelIsa::kAvx512:
      return true;
#endif
    default:
      return false;
  }
}

}  // namespace

std::string_view to_string(TriangleTestKind kind) {
  return name_of(kTriangleNames, kind);
}
std::string_view to_string(BoxTestKind kind) {
  return name_of(kBoxNames, kind);
}
std::string_view to_string(KernelIsa isa) {
  return name_of(kIsaNames, isa);
}
std::string_view to_string(AnyHitOrder order) {
  return name_of(kAnyHitOrderNames, order);
}
std::optional<TriangleTestKind> parse_triangle_test(std::string_view name) {
  return value_of(kTriangleNames, name);
}
std::optional<BoxTestKind> parse_box_test(std::string_view name) {
  return value_of(kBoxNames, name);
}
std::optional<KernelIsa> parse_kernel_isa(std::string_view name) {
  return value_of(kIsaNames, name);
}
std::optional<AnyHitOrder> parse_any_hit_order(std::string_view name) {
  return value_of(kAnyHitOrderNames, name);
}
std::string any_hit_order_names(std::string_view separator) {
  std::string out;
  for (const auto& [order, name] : kAnyHitOrderNames) {
    if (!out.empty()) out += separator;
    out += name;
  }
  return out;
}

bool cpu_supports_kernel_isa(KernelIsa isa) {
  return cpu_supports(isa);
}

bool kernel_isa_available(KernelIsa isa) {
  if (isa == KernelIsa::kAuto) return false;
  return compiled_in(isa) && cpu_supports(isa);
}

KernelIsa best_kernel_isa(KernelIsa widest) {
  for (KernelIsa isa : {KernelIsa::kAvx512, KernelIsa::kAvx2, KernelIsa::kSse}) {
    if (widest != KernelIsa::kAuto && static_cast<int>(isa) > static_cast<int>(widest)) continue;
    if (kernel_isa_available(isa)) return isa;
  }
  return KernelIsa::kScalar;
}

KernelIsa preferred_kernel_isa() {
  return best_kernel_isa();
}

}  // namespace sahbench
