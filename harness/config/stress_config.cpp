#include "harness/config/stress_config.h"

#include <toml++/toml.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <set>
#include <sstream>

#include "builders/registry.h"
#include "core/error.h"
#include "core/text_file.h"
#include "harness/config/config.h"
#include "harness/config/toml_file.h"
#include "traversal/layout.h"

namespace sahbench {
namespace {

// Bounds on sizes: a typo must fail at once, not as an allocation failure or an hour-long case.
constexpr int64_t kMaxCaseTriangles = 10'000'000;
constexpr int64_t kMaxCaseRays = 10'000'000;
constexpr int64_t kMaxReps = 1000;
constexpr int64_t kMaxThreads = 1024;
constexpr double kMaxTimeLimitS = 86400.0;

void read_settings(const Source& r, const toml::table& root, StressConfig& c) {
  const toml::node* node = root.get("stress");
  if (!node) throw Error(c.path.string() + ":1: missing table [stress]");
  const auto* t = node->as_table();
  if (!t) r.fail(*node, "stress must be a table");
  check_keys(r, *t, "[stress]",
             {"name", "output", "rays", "threads", "trace_reps", "trace_warmup", "build_time_limit_s",
              "builders", "layouts", "embree"});
  const toml::node* name = t->get("name");
  if (!name) r.fail(*node, "[stress] needs a name");
  c.name = read_name(r, *name, "stress.name");
  c.output = "results/" + c.name + ".csv";
  if (const auto* v = t->get("output")) c.output = read_string(r, *v, "stress.output");
  if (const auto* v = t->get("rays"))
    c.rays = static_cast<uint32_t>(read_int(r, *v, "stress.rays", 1, kMaxCaseRays));
  if (const auto* v = t->get("threads"))
    c.threads = static_cast<int>(read_int(r, *v, "stress.threads", 1, kMaxThreads));
  if (const auto* v = t->get("trace_reps"))
    c.trace_reps = static_cast<int>(read_int(r, *v, "stress.trace_reps", 1, kMaxReps));
  if (const auto* v = t->get("trace_warmup"))
    c.trace_warmup = static_cast<int>(read_int(r, *v, "stress.trace_warmup", 0, kMaxReps));
  if (const auto* v = t->get("build_time_limit_s"))
    c.build_time_limit_s = read_real(r, *v, "stress.build_time_limit_s", 0.001, kMaxTimeLimitS);

  c.builders = all_builder_specs();
  if (const auto* v = t->get("builders")) {
    const std::vector<std::string> texts = read_string_list(r, *v, "stress.builders", false);
    const auto& list = *v->as_array();
    c.builders.clear();
    for (std::size_t i = 0; i < texts.size(); ++i) {
      try {
        BuilderRun spec = parse_builder_run(texts[i]);
        if (spec.is_embree()) throw Error("Embree's own BVH is run through stress.embree, not as a builder");
        resolve(spec);
        c.builders.push_back(std::move(spec));
      } catch (const Error& e) {
        r.fail(*list.get(i), "stress.builders: " + std::string(e.what()));
      }
    }
  }
  c.layouts = all_layout_variants();
  if (const auto* v = t->get("layouts")) {
    const std::vector<std::string> texts = read_string_list(r, *v, "stress.layouts", false);
    const auto& list = *v->as_array();
    c.layouts.clear();
    for (std::size_t i = 0; i < texts.size(); ++i) {
      try {
        c.layouts.push_back(parse_layout_spec(texts[i]));
      } catch (const Error& e) {
        r.fail(*list.get(i), "stress.layouts: " + std::string(e.what()));
      }
    }
  }
  if (const auto* v = t->get("embree")) {
    c.embree_robust.clear();
    const auto modes = read_string_list(r, *v, "stress.embree", true);
    const auto& list = *v->as_array();
    for (std::size_t i = 0; i < modes.size(); ++i) {
      if (modes[i] != "default" && modes[i] != "robust")
        r.fail(*list.get(i), "stress.embree = \"" + modes[i] + "\" is not one of default | robust");
      c.embree_robust.push_back(modes[i] == "robust");
    }
  }
}

void read_cases(const Source& r, const toml::table& root, StressConfig& c) {
  const toml::node* node = root.get("case");
  if (!node) throw Error(c.path.string() + ":1: no [[case]] tables: a stress config needs at least one");
  const auto* list = node->as_array();
  if (!list || !list->is_array_of_tables()) r.fail(*node, "case must be [[case]] tables");
  for (const auto& item : *list) {
    const auto& t = *item.as_table();
    check_keys(r, t, "[[case]]",
               {"name", "kind", "seed", "size", "rays", "scale", "offset", "aspect", "outer"});
    StressCaseSpec s;
    const toml::node* name = t.get("name");
    const toml::node* kind = t.get("kind");
    if (!name || !kind) r.fail(item, "[[case]] needs a name and a kind");
    s.name = read_name(r, *name, "case.name");
    for (const auto& other : c.cases)
      if (other.name == s.name) r.fail(*name, "case name \"" + s.name + "\" is used twice");
    s.kind = read_string(r, *kind, "case.kind");
    const StressKindInfo* info = nullptr;
    try {
      info = &find_stress_kind(s.kind);
    } catch (const Error& e) {
      r.fail(*kind, e.what());
    }
    const std::string where = "case " + s.name + ": ";
    s.rays = c.rays;
    if (const auto* v = t.get("seed"))
      s.seed = static_cast<uint64_t>(read_int(r, *v, where + "seed", 0, std::numeric_limits<int64_t>::max()));
    if (const auto* v = t.get("size"))
      s.size = static_cast<uint64_t>(read_int(r, *v, where + "size", 1, kMaxCaseTriangles));
    if (const auto* v = t.get("rays"))
      s.rays = static_cast<uint32_t>(read_int(r, *v, where + "rays", 1, kMaxCaseRays));
    // Real parameters: only those the kind reads, so that none is silently ignored.
    struct Real {
      const char* key;
      double* value;
      double min, max;
    };
    const Real reals[] = {{"scale", &s.scale, 1e-30, 1e30},
                          {"offset", &s.offset, -1e30, 1e30},
                          {"aspect", &s.aspect, 1.0, 1e12},
                          {"outer", &s.outer, 2.0, 1e30}};
    for (const Real& real : reals) {
      const toml::node* v = t.get(real.key);
      if (!v) continue;
      if (std::find(info->params.begin(), info->params.end(), real.key) == info->params.end())
        r.fail(*v, where + "kind " + s.kind + " does not read '" + real.key + "'");
      *real.value = read_real(r, *v, where + real.key, real.min, real.max);
    }
    c.cases.push_back(std::move(s));
  }
}

}  // namespace

std::vector<BuilderRun> all_builder_specs() {
  std::set<uint32_t> layout_arities;
  for (const auto& layout : layouts()) layout_arities.insert(layout.arity);
  std::vector<BuilderRun> out;
  for (const auto& b : builders()) {
    // A builder that reads its tree from a file (`file`) has a tree for one scene only, never for the
    // suite's generated ones.
    if (std::any_of(b.params.begin(), b.params.end(),
                    [](const ParamSpec& p) { return p.type == ParamType::kPath; }))
      continue;
    out.push_back({b.name, {}});
    // A builder with an `arity` parameter also runs at every other arity some layout traverses, so
    // that every layout gets a tree.
    const bool has_arity =
        std::any_of(b.params.begin(), b.params.end(), [](const ParamSpec& p) { return p.name == "arity"; });
    if (!has_arity || !b.arity) continue;
    const uint32_t default_arity = b.arity(resolve_params(b.name, b.params, {}));
    for (const uint32_t arity : layout_arities)
      if (arity != default_arity && arity != 2) out.push_back({b.name, {{"arity", std::to_string(arity)}}});
  }
  for (BuilderRun& run : out) resolve(run);
  return out;
}

std::vector<LayoutSpec> all_layout_variants() {
  std::vector<LayoutSpec> out;
  for (const auto& layout : layouts())
    for (const auto tri :
         {TriangleTestKind::kWatertight, TriangleTestKind::kMollerTrumbore,
          TriangleTestKind::kMollerTrumboreNoEpsilon, TriangleTestKind::kMollerTrumboreNormal})
      for (const auto box : {BoxTestKind::kRobust, BoxTestKind::kFast, BoxTestKind::kFma}) {
        LayoutSpec spec;
        spec.name = layout.name;
        spec.variant = {tri, box};
        out.push_back(spec);
      }
  return out;
}

StressConfig load_stress_config(const std::filesystem::path& path) {
  return parse_stress_config(read_text_file(path, "stress config"), path.string());
}

StressConfig parse_stress_config(std::string_view toml_text, const std::string& source_name) {
  const toml::table root = parse_toml(toml_text, source_name);
  const Source r{source_name};
  check_keys(r, root, "the top level", {"stress", "case"});
  StressConfig c;
  c.path = source_name;
  read_settings(r, root, c);
  read_cases(r, root, c);
  return c;
}

}  // namespace sahbench
