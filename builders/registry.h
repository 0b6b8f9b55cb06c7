#pragma once
// Maps builder names to builders. A config or the CLI names a builder and overrides any of its declared
// parameters; unknown names and parameters are errors that name them.

#include <functional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "builders/params.h"
#include "core/build_input.h"
#include "core/bvh.h"
#include "core/sah.h"

namespace sahbench {

struct BuilderInfo {
  std::string name;
  std::string summary;  ///< one line, with the paper it implements
  std::vector<ParamSpec> params;
  std::function<Bvh(const BuildInput&, const ParamSet&)> build;
  /// Checks a combination of parameters that each lie in range but may not fit together (min_leaf above
  /// max_leaf, say), so configs fail when loaded rather than when the builder's turn comes. Optional.
  std::function<void(const ParamSet&)> check;
  /// The arity of the trees built with these parameters, so the harness can pair the builder with
  /// layouts before building. Optional: empty means binary.
  std::function<uint32_t(const ParamSet&)> arity = {};
};

/// Every registered builder, in registration order.
std::span<const BuilderInfo> builders();

/// Adds a builder defined outside this layer (e.g. the harness's Embree-backed builders, which this
/// layer must not know about). A name already registered is an error. Not thread-safe: call at startup.
void register_builder(BuilderInfo info);

/// The builder called `name`; an unknown name is an error listing the known ones.
const BuilderInfo& find_builder(std::string_view name);

/// The tree of the tree source `key` of a pass (a kSource parameter of `params`), built from `input` by
/// the source's builder with its own parameters. A shared source (SourceSpec::shared) is the pass's own
/// to build; asking for it here is an Error.
Bvh build_source(const BuildInput& input, const ParamSet& params, std::string_view key = "source");

/// The SAH constants a builder ran with (every builder declares c_trav and c_isect), for statistics
/// and the CSV.
SahCost sah_cost_of(const ParamSet& params);

}  // namespace sahbench
