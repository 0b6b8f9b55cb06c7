#include "builders/top_down.h"

#include <string>

namespace sahbench {

void check_config(const TopDownConfig& config, std::string_view builder) {
  const std::string name(builder);
  if (config.min_leaf < 1)
    throw Error(name + ": min_leaf = " + std::to_string(config.min_leaf) + " must be at least 1");
  if (config.max_leaf < config.min_leaf)
    throw Error(name + ": max_leaf = " + std::to_string(config.max_leaf) +
                " is below min_leaf = " + std::to_string(config.min_leaf));
  if (config.max_leaf > kMaxLeafPrims)
    throw Error(name + ": max_leaf = " + std::to_string(config.max_leaf) +
                " exceeds the node format's limit of " + std::to_string(kMaxLeafPrims));
  if (config.arity != 2 && config.arity != 4 && config.arity != 8)
    throw Error(name + ": arity = " + std::to_string(config.arity) +
                " must be 2, 4 or 8 (the common format's widths)");
  if (config.cost.block == 0 || config.cost.block > 16 || (config.cost.block & (config.cost.block - 1)) != 0)
    throw Error(name + ": sah_block = " + std::to_string(config.cost.block) +
                " must be a power of two up to 16");
  if (!(config.cost.c_trav >= 0.0f) || !(config.cost.c_isect > 0.0f))
    throw Error(name + ": SAH constants must be c_trav >= 0 and c_isect > 0 (got c_trav = " +
                std::to_string(config.cost.c_trav) + ", c_isect = " + std::to_string(config.cost.c_isect) +
                ")");
}

void check_prim_count(std::size_t count, std::string_view builder) {
  // The slot buffer holds 2n - 1 nodes indexed by uint32.
  constexpr std::size_t kMaxPrims = (std::size_t{1} << 31) - 1;
  if (count > kMaxPrims)
    throw Error(std::string(builder) + ": " + std::to_string(count) + " primitives exceed the limit of " +
                std::to_string(kMaxPrims));
}

}  // namespace sahbench
