// The layout registry (names and what each takes), the spec syntax and what a CPU can run: everything a
// config needs to check a layout, without the kernels (layouts.cpp compiles the layouts), so that the
// config readers and their fuzzers build without them.

#include <algorithm>

#include "core/error.h"
#include "traversal/layout.h"

namespace sahbench {
namespace {

const std::vector<LayoutInfo>& registry() {
  static const std::vector<LayoutInfo> all = {
      {"bvh2", "the common format as built: 32-byte nodes, triangles through references, packets of 8 or 16",
       2, false, true},
      {"bvh2_packed",
       "64-byte nodes holding both children's boxes, triangles copied into leaf order, packets of 8 or 16", 2,
       false, true},
      {"bvh4", "4-wide SoA nodes (128 B), triangles packed 4 per block, SIMD kernels (sse/avx2/avx512)", 4,
       true, true},
      {"bvh8",
       "8-wide SoA nodes (256 B), triangles packed 4 per block, SIMD kernels (avx2/avx512, sse in halves)", 8,
       true, true},
  };
  return all;
}

// Whether kernels for `isa` run here, on a CPU capped at `widest` (kAuto: no cap).
bool available_up_to(KernelIsa isa, KernelIsa widest) {
  return kernel_isa_available(isa) &&
         (widest == KernelIsa::kAuto || static_cast<int>(isa) <= static_cast<int>(widest));
}

// Why the kernels of `spec` (an instruction set, a packet width) cannot run here; nullopt when they can.
std::optional<std::string> kernels_unavailable(const LayoutSpec& spec, KernelIsa widest) {
  const KernelIsa isa = layout_kernel_isa(spec, widest);
  std::string why;
  if (spec.packet == 16 && isa != KernelIsa::kAvx512)
    why = "16-ray packets need AVX-512, which this CPU or build lacks";
  else if (spec.packet == 8 && isa != KernelIsa::kAvx2 && isa != KernelIsa::kAvx512)
    why = "8-ray packets need AVX2 or AVX-512, which this CPU or build lacks";
  else if (!available_up_to(isa, widest))
    why = "isa " + std::string(to_string(isa)) + " is not available on this CPU or build";
  else
    return std::nullopt;
  return why + " (auto would pick " + std::string(to_string(layout_kernel_isa({}, widest))) + ")";
}

}  // namespace

std::span<const LayoutInfo> layouts() {
  return registry();
}

const LayoutInfo& find_layout(std::string_view name) {
  for (const auto& l : registry())
    if (l.name == name) return l;
  std::string known;
  for (const auto& l : registry()) known += (known.empty() ? "" : ", ") + l.name;
  throw Error("unknown layout '" + std::string(name) + "' (known: " + known + ")");
}

std::string LayoutSpec::text() const {
  std::string options;
  auto add = [&](std::string_view key, std::string_view value) {
    options += options.empty() ? ':' : ',';
    options.append(key).append("=").append(value);
  };
  const KernelVariant defaults;
  if (variant.triangle != defaults.triangle) add("tri", to_string(variant.triangle));
  if (variant.box != defaults.box) add("box", to_string(variant.box));
  if (variant.any_hit != defaults.any_hit) add("anyhit", to_string(variant.any_hit));
  if (isa != KernelIsa::kAuto) add("isa", to_string(isa));
  if (packet != 1) add("packet", std::to_string(packet));
  if (!shadow_cache) add("shadow_cache", "off");
  return name + options;
}

LayoutSpec parse_layout_spec(std::string_view text) {
  LayoutSpec spec;
  const auto colon = text.find(':');
  spec.name = std::string(text.substr(0, colon));
  const LayoutInfo& info = find_layout(spec.name);
  if (colon == std::string_view::npos) return spec;

  const std::string where = "layout '" + std::string(text) + "'";
  // The binary layouts take `isa` with `packet` only: it picks their packet kernels' build, while
  // their single-ray kernel has one, the baseline's.
  const bool takes_isa = info.has_isa || info.has_packet;
  const std::string keys = std::string("tri, box, anyhit") + (takes_isa ? ", isa" : "") +
                           (info.has_packet ? ", packet" : "") + (info.has_isa ? ", shadow_cache" : "");
  std::string_view rest = text.substr(colon + 1);
  std::vector<std::string> seen;
  while (true) {
    const auto comma = rest.find(',');
    const std::string_view item = rest.substr(0, comma);
    const auto eq = item.find('=');
    if (eq == std::string_view::npos || eq == 0)
      throw Error(where + ": option '" + std::string(item) + "' is not of the form key=value (keys: " + keys +
                  ")");
    const std::string key(item.substr(0, eq));
    const std::string value(item.substr(eq + 1));
    if (std::find(seen.begin(), seen.end(), key) != seen.end())
      throw Error(where + ": option '" + key + "' is given twice");
    seen.push_back(key);
    if (key == "tri") {
      const auto kind = parse_triangle_test(value);
      if (!kind) throw Error(where + ": tri = '" + value + "' is not one of watertight, mt, mt0, mtn");
      spec.variant.triangle = *kind;
    } else if (key == "box") {
      const auto kind = parse_box_test(value);
      if (!kind) throw Error(where + ": box = '" + value + "' is not one of robust, fast, fma");
      spec.variant.box = *kind;
    } else if (key == "anyhit") {
      const auto order = parse_any_hit_order(value);
      if (!order)
        throw Error(where + ": anyhit = '" + value + "' is not one of " + any_hit_order_names(", "));
      spec.variant.any_hit = *order;
    } else if (key == "isa" && takes_isa) {
      const auto isa = parse_kernel_isa(value);
      if (!isa) throw Error(where + ": isa = '" + value + "' is not one of auto, scalar, sse, avx2, avx512");
      spec.isa = *isa;
    } else if (key == "packet" && info.has_packet) {
      if (value == "1" || value == "8" || value == "16")
        spec.packet = static_cast<uint32_t>(std::stoul(value));
      else
        throw Error(where + ": packet = '" + value + "' is not one of 1, 8, 16");
    } else if (key == "shadow_cache" && info.has_isa) {
      if (value != "on" && value != "off")
        throw Error(where + ": shadow_cache = '" + value + "' is not on or off");
      spec.shadow_cache = value == "on";
    } else {
      throw Error(where + ": unknown option '" + key + "' (known: " + keys + ")");
    }
    if (comma == std::string_view::npos) break;
    rest = rest.substr(comma + 1);
  }
  if (!info.has_isa && spec.isa != KernelIsa::kAuto && spec.packet == 1)
    throw Error(where + ": isa picks the build of " + spec.name +
                "'s packet kernels; its single-ray kernel has one build (add packet=8 or packet=16)");
  // Packet kernels exist for AVX2 and AVX-512 (8 rays) and AVX-512 (16 rays) only.
  const bool packet_isa = spec.isa == KernelIsa::kAuto || spec.isa == KernelIsa::kAvx512 ||
                          (spec.packet == 8 && spec.isa == KernelIsa::kAvx2);
  if (spec.packet != 1 && !packet_isa)
    throw Error(where + ": no " + std::string(to_string(spec.isa)) + " kernels for packet=" +
                std::to_string(spec.packet) + " (packet=8: isa avx2 or avx512; packet=16: isa avx512)");
  return spec;
}

KernelIsa layout_kernel_isa(const LayoutSpec& spec, KernelIsa widest) {
  if (spec.isa != KernelIsa::kAuto) return spec.isa;
  const KernelIsa preferred = preferred_kernel_isa();
  return available_up_to(preferred, widest) ? preferred : best_kernel_isa(widest);
}

std::optional<std::string> layout_unavailable(const LayoutSpec& spec, KernelIsa widest) {
  return find_layout(spec.name).has_isa || spec.packet != 1 ? kernels_unavailable(spec, widest)
                                                            : std::nullopt;
}

bool layout_depends_on_cpu(const LayoutSpec& spec) {
  return spec.packet != 1 || (spec.isa != KernelIsa::kAuto && spec.isa != KernelIsa::kScalar);
}

}  // namespace sahbench
