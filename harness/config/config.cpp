#include "harness/config/config.h"

#include <toml++/toml.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <limits>
#include <map>

#include "builders/registry.h"
#include "core/error.h"
#include "core/text_file.h"
#include "harness/config/toml_file.h"
#include "harness/embree/embree_scene.h"
#include "scenes/camera.h"
#include "scenes/load.h"
#include "scenes/proc_spec.h"
#include "scenes/procedural.h"
#include "traversal/layout.h"

namespace sahbench {
namespace {

constexpr int kMaxInt = std::numeric_limits<int>::max();
constexpr int64_t kMaxUint32 = std::numeric_limits<uint32_t>::max();
constexpr int64_t kMaxInt64 = std::numeric_limits<int64_t>::max();

// The config's spelling of each enumerator; a ray kind's is also the default name of its ray sets.
const Spellings<RayKind> kRayKinds = {{"primary", RayKind::kPrimary},
                                      {"shadow", RayKind::kShadow},
                                      {"diffuse", RayKind::kDiffuse},
                                      {"ao", RayKind::kAmbientOcclusion},
                                      {"random", RayKind::kRandom}};
const Spellings<ReferencePolicy> kReferencePolicies = {{"auto", ReferencePolicy::kAuto},
                                                       {"embree", ReferencePolicy::kEmbree},
                                                       {"brute_force", ReferencePolicy::kBruteForce},
                                                       {"none", ReferencePolicy::kNone}};

// Embree's robust parameter: a TOML boolean (which reaches here as 1 or 0), or on the command line 1, 0,
// true or false.
bool parse_embree_robust(std::string_view text) {
  if (text == "1" || text == "true") return true;
  if (text == "0" || text == "false") return false;
  throw Error("embree: robust = '" + std::string(text) + "' is not one of true, false (or 1, 0)");
}

// Embree's parameters in their one spelling (BuilderRun::params): quality first, medium unless given,
// then robust=1 in robust mode only. Every value is checked.
ParamOverrides embree_params(const ParamOverrides& given) {
  std::string quality = "medium";
  bool robust = false;
  for (const auto& [key, value] : given) {
    if (key == "quality") {
      parse_embree_quality(value);
      quality = value;
    } else if (key == "robust") {
      robust = parse_embree_robust(value);
    } else {
      throw Error("embree: unknown parameter '" + key + "' (known: quality, robust)");
    }
  }
  ParamOverrides out = {{"quality", quality}};
  if (robust) out.emplace_back("robust", "1");
  return out;
}

// An integer or a non-empty list of distinct integers, each at least 1.
std::vector<int> read_threads(const Source& src, const toml::node& node) {
  const std::string key = "experiment.threads";
  const std::string must = key + " must be an integer or a list of integers";
  if (node.is_integer()) return {static_cast<int>(read_int(src, node, key, 1, kMaxInt))};
  if (!node.is_array()) src.fail(node, must + ", not " + type_name(node));
  std::vector<int> out;
  for (const auto& item : read_list(src, node, key, "integers")) {
    if (!item.is_integer()) src.fail(item, must + ", not contain " + type_name(item));
    const int t = static_cast<int>(read_int(src, item, key, 1, kMaxInt));
    if (std::find(out.begin(), out.end(), t) != out.end())
      src.fail(item, key + " lists " + std::to_string(t) + " twice");
    out.push_back(t);
  }
  return out;
}

// The value of one builder parameter as a ParamOverrides string.
std::string param_text(const Source& src, const toml::node& node, const std::string& key) {
  if (const auto* v = node.as_string()) return v->get();
  if (const auto* v = node.as_integer()) return std::to_string(v->get());
  if (const auto* v = node.as_boolean()) return v->get() ? "1" : "0";
  if (const auto* v = node.as_floating_point()) {
    // Shortest text that reads back to the same double (so 0.1 stays "0.1").
    char buf[32];
    const auto result = std::to_chars(buf, buf + sizeof buf, v->get());
    return std::string(buf, result.ptr);
  }
  src.fail(node, "builder parameter '" + key +
                     "' must be an integer, float, string or boolean, or a list of them, not " +
                     type_name(node));
}

void read_experiment(const Source& src, const toml::table& root, ExperimentConfig& config) {
  const auto* node = root.get("experiment");
  if (!node) src.fail(1, "missing [experiment] table (it needs at least `name` and `scenes`)");
  const auto& table = as_table(src, *node, "[experiment]");
  check_keys(src, table, "[experiment]",
             {"name", "output", "seed", "threads", "scenes", "optional_scenes", "layouts", "reference",
              "brute_force_max_triangles", "epo"});

  const auto* name = table.get("name");
  if (!name) src.fail(table, "[experiment] has no name (name = \"...\")");
  config.name = read_name(src, *name, "experiment.name");
  config.output = "results/" + config.name + ".csv";
  if (const auto* n = table.get("output")) config.output = read_string(src, *n, "experiment.output");
  if (const auto* n = table.get("seed")) config.seed = read_int(src, *n, "experiment.seed", 0, kMaxInt64);
  if (const auto* n = table.get("threads")) config.threads = read_threads(src, *n);
  if (const auto* n = table.get("scenes")) config.scenes = read_string_list(src, *n, "experiment.scenes");
  if (const auto* n = table.get("optional_scenes"))
    config.optional_scenes = read_string_list(src, *n, "experiment.optional_scenes");
  for (const auto& scene : config.optional_scenes)
    if (std::find(config.scenes.begin(), config.scenes.end(), scene) != config.scenes.end())
      src.fail(*table.get("optional_scenes"),
               "scene \"" + scene + "\" is in both scenes and optional_scenes");
  if (config.scenes.empty() && config.optional_scenes.empty())
    src.fail(table, "[experiment] names no scene: give scenes or optional_scenes");
  // A procedural spec is checked here, where its line is known: an optional one with a typo would
  // otherwise be skipped as "not found". And one scene under two spellings (tris=10k and tris=10000, a
  // shared scene's name and its path) would be measured twice.
  std::map<std::string, std::string> spellings;  // the scene it is -> how the config first spelled it
  for (const char* list : {"scenes", "optional_scenes"}) {
    for (const auto& scene : list == std::string_view("scenes") ? config.scenes : config.optional_scenes) {
      std::string identity = scene;
      if (is_procedural_spec(scene)) {
        try {
          identity = parse_proc_spec(scene, procedural_kinds()).normalised();
        } catch (const Error& e) {
          src.fail(*table.get(list), std::string("experiment.") + list + ": " + e.what());
        }
      } else if (const auto file = scene_file_of(scene)) {
        std::error_code ec;
        const std::filesystem::path canonical = std::filesystem::weakly_canonical(*file, ec);
        if (!ec) identity = canonical.string();
      }
      const auto [it, added] = spellings.emplace(identity, scene);
      if (!added)
        src.fail(*table.get(list), "scenes \"" + it->second + "\" and \"" + scene +
                                       "\" are the same scene (" + identity + "): list it once");
    }
  }

  if (const auto* n = table.get("layouts")) {
    config.layouts.clear();
    for (const auto& item : read_list(src, *n, "experiment.layouts", "strings")) {
      if (!item.is_string())
        src.fail(item, "experiment.layouts must be a list of strings, not contain " + type_name(item));
      LayoutSpec layout;
      try {
        layout = parse_layout_spec(read_string(src, item, "experiment.layouts item"));
      } catch (const Error& e) {
        src.fail(item, std::string("experiment.layouts: ") + e.what());
      }
      if (std::find(config.layouts.begin(), config.layouts.end(), layout) != config.layouts.end())
        src.fail(item, "experiment.layouts lists \"" + layout.text() + "\" twice");
      config.layouts.push_back(layout);
    }
  }

  if (const auto* n = table.get("reference"))
    config.reference = read_enum(src, *n, "experiment.reference", kReferencePolicies);
  if (const auto* n = table.get("brute_force_max_triangles")) {
    if (config.reference != ReferencePolicy::kAuto)
      src.fail(*n, "experiment.brute_force_max_triangles applies only with reference = \"auto\"");
    config.brute_force_max_triangles =
        read_int(src, *n, "experiment.brute_force_max_triangles", 0, kMaxInt64);
  }
  if (const auto* n = table.get("epo")) {
    const auto* value = n->as_boolean();
    if (value == nullptr) src.fail(*n, "experiment.epo must be true or false, not " + type_name(*n));
    config.epo = value->get();
  }
}

void read_repetitions(const Source& src, const toml::node& node, Repetitions& reps) {
  const auto& table = as_table(src, node, "[repetitions]");
  check_keys(src, table, "[repetitions]", {"build", "build_warmup", "trace", "trace_warmup", "interleave"});
  const auto read = [&](const char* key, int64_t min, int& out) {
    if (const auto* n = table.get(key))
      out = static_cast<int>(read_int(src, *n, std::string("repetitions.") + key, min, kMaxInt));
  };
  read("build", 1, reps.build);
  read("build_warmup", 0, reps.build_warmup);
  read("trace", 1, reps.trace);
  read("trace_warmup", 0, reps.trace_warmup);
  if (const auto* n = table.get("interleave")) {
    const auto* value = n->as_boolean();
    if (value == nullptr) src.fail(*n, "repetitions.interleave must be true or false");
    reps.interleave = value->get();
  }
}

// [animation]: the frames of an animation experiment, as a count or as explicit times.
void read_animation(const Source& src, const toml::node& node, ExperimentConfig& config) {
  const auto& table = as_table(src, node, "[animation]");
  check_keys(src, table, "[animation]", {"frames", "times"});
  AnimationConfig animation;
  const auto* frames = table.get("frames");
  const auto* times = table.get("times");
  if (frames && times) src.fail(*times, "animation.times and animation.frames exclude each other: give one");
  if (frames)
    animation.frames = static_cast<uint32_t>(read_int(src, *frames, "animation.frames", 1, kMaxFrames));
  if (times) {
    const std::string must = "animation.times must be a list of numbers (seconds)";
    const toml::node* previous = nullptr;
    for (const auto& item : read_list(src, *times, "animation.times", "numbers")) {
      if (!item.is_number()) src.fail(item, must + ", not contain " + type_name(item));
      const double t = item.is_integer() ? double(item.as_integer()->get()) : item.as_floating_point()->get();
      if (!std::isfinite(t))
        src.fail(item, "animation.times: " + param_text(src, item, "times") + " is not finite");
      if (previous && t <= animation.times.back())
        src.fail(item, "animation.times must increase: " + param_text(src, item, "times") + " follows " +
                           param_text(src, *previous, "times"));
      animation.times.push_back(t);
      previous = &item;
    }
    if (animation.times.size() > kMaxFrames)
      src.fail(*times, "animation.times lists more than " + std::to_string(kMaxFrames) + " times");
    animation.frames = static_cast<uint32_t>(animation.times.size());
  }
  config.animation = std::move(animation);
}

// One builder parameter with all of its values (one unless swept), each with its line. A nested source's
// parameters are keyed by their dotted path ("source.iterations").
struct SweepKey {
  std::string key;
  std::vector<std::pair<std::string, const toml::node*>> values;
};

// The value or list of values of `key` (a list sweeps), each as a ParamOverrides string with its node.
SweepKey read_sweep(const Source& src, const std::string& key, const toml::node& node) {
  SweepKey sweep{key, {}};
  if (const auto* list = node.as_array()) {
    if (list->empty()) src.fail(node, "builder parameter '" + key + "' must not be an empty list");
    for (const auto& item : *list) {
      if (item.is_array() || item.is_table())
        src.fail(item, "builder parameter '" + key + "' lists " + type_name(item) + "; lists may not nest");
      sweep.values.emplace_back(param_text(src, item, key), &item);
    }
  } else {
    sweep.values.emplace_back(param_text(src, node, key), &node);
  }
  return sweep;
}

// The values of a path parameter (`key` of `info`, ParamType::kPath) made relative to the config's folder,
// so that a config and the files it names move together; the run, and builder_params, see the joined path.
void resolve_paths(const Source& src, const BuilderInfo& info, const std::string& key, SweepKey& sweep) {
  const auto spec =
      std::find_if(info.params.begin(), info.params.end(), [&](const ParamSpec& p) { return p.name == key; });
  if (spec == info.params.end() || spec->type != ParamType::kPath) return;
  const std::filesystem::path folder = std::filesystem::path(src.file).parent_path();
  for (auto& value : sweep.values) {
    const std::filesystem::path path(value.first);
    if (!value.first.empty() && path.is_relative()) value.first = (folder / path).lexically_normal().string();
  }
}

// A number written as a string, or a boolean where the parameter is no 0/1 switch, is a mistake TOML's
// types can name: `radius = "16"` or `radius = true` would otherwise read as 16 and 1.
void check_value_types(const Source& src, const BuilderInfo& info, const std::string& key,
                       const SweepKey& sweep) {
  const auto spec =
      std::find_if(info.params.begin(), info.params.end(), [&](const ParamSpec& p) { return p.name == key; });
  if (spec == info.params.end()) return;  // resolve_params names the unknown key
  const bool number = spec->type == ParamType::kInt || spec->type == ParamType::kFloat;
  const bool switch01 = spec->type == ParamType::kInt && spec->min_value == 0 && spec->max_value == 1;
  for (const auto& [text, node] : sweep.values) {
    if (number && node->is_string())
      src.fail(*node, info.name + ": parameter '" + key + "' takes a number, not the string \"" + text +
                          "\" (write it without quotes)");
    if (node->is_boolean() && !switch01)
      src.fail(*node, info.name + ": parameter '" + key + "' takes " + (number ? "a number" : "a name") +
                          ", not " + (text == "1" ? "true" : "false"));
    // A path or a name written as a number (`path = 5`) would look for a file or a choice called "5".
    if ((spec->type == ParamType::kPath || spec->type == ParamType::kChoice) &&
        (node->is_integer() || node->is_floating_point()))
      src.fail(*node, info.name + ": parameter '" + key + "' takes " +
                          (spec->type == ParamType::kPath ? "a file path" : "a name") +
                          " in quotes, not the number " + text);
  }
}

// Whether parameter `key` of `info` is a tree source, whose value may be a table.
bool is_source_param(const BuilderInfo& info, const std::string& key) {
  return std::any_of(info.params.begin(), info.params.end(),
                     [&](const ParamSpec& p) { return p.name == key && p.type == ParamType::kSource; });
}

// A tree source written as a table, `param = { name = "reinsert", iterations = 2, source = {...} }` or
// `[builder.param]`, the value of source parameter `param` of `owner`: read into the dotted keys of
// ParamOverrides under `path` (param = name, param.KEY = value, ...), each value checked against the
// builder it belongs to at its own line, and the whole source, unless it sweeps, at its name's.
void read_source_table(const Source& src, const toml::table& table, const BuilderInfo& owner,
                       const std::string& param, const std::string& path, std::vector<SweepKey>& keys) {
  const auto* name_node = table.get("name");
  if (!name_node) src.fail(table, "tree source '" + path + "' has no name (name = \"binned_sah\", ...)");
  const std::string name = read_string(src, *name_node, path + ".name");
  const BuilderInfo* info = nullptr;
  try {
    info = &find_builder(name);
  } catch (const Error& e) {
    src.fail(*name_node, owner.name + ": parameter '" + param + "': " + e.what());
  }
  const std::size_t first_key = keys.size();
  keys.push_back({path, {{name, name_node}}});
  for (const auto& [key, node] : in_file_order(table)) {
    if (key == "name") continue;
    const std::string nested = path + "." + key;
    if (node->is_table() && is_source_param(*info, key)) {
      read_source_table(src, *node->as_table(), *info, key, nested, keys);
      continue;
    }
    SweepKey sweep = read_sweep(src, nested, *node);
    resolve_paths(src, *info, key, sweep);
    check_value_types(src, *info, key, sweep);
    for (const auto& [text, at] : sweep.values) {
      try {
        resolve_params(info->name, info->params, {{key, text}});
      } catch (const Error& e) {
        src.fail(*at, "tree source '" + path + "': " + e.what());
      }
    }
    keys.push_back(std::move(sweep));
  }
  // Parameters that are valid one by one may not fit together (a wide source, min_leaf above max_leaf).
  ParamOverrides together;
  const std::size_t strip = path.size() - param.size();  // the owner's own prefix
  for (std::size_t k = first_key; k < keys.size(); ++k) {
    if (keys[k].values.size() != 1) return;  // a sweep: each run is resolved as it is expanded
    together.emplace_back(keys[k].key.substr(strip), keys[k].values.front().first);
  }
  try {
    resolve_params(owner.name, owner.params, together);
  } catch (const Error& e) {
    src.fail(*name_node, e.what());
  }
}

// Expands one [[builder]] table into its runs, checking every value against the builder's declaration.
std::vector<BuilderRun> read_builder(const Source& src, const toml::table& table, bool animation) {
  const auto* name_node = table.get("name");
  if (!name_node) src.fail(table, "[[builder]] has no name (name = \"...\")");
  const std::string name = read_string(src, *name_node, "builder.name");
  const bool embree = name == "embree";
  const BuilderInfo* info = nullptr;
  if (!embree) {
    try {
      info = &find_builder(name);
    } catch (const Error& e) {
      src.fail(*name_node, e.what());
    }
  }

  // Collect the parameters in file order, checking each value on its own so an error names its line.
  std::vector<SweepKey> keys;
  for (const auto& [key, node] : in_file_order(table)) {
    if (key == "name") continue;
    if (embree && key != "quality" && key != "robust")
      src.fail(*node, "embree: unknown parameter '" + key + "' (known: quality, robust)");
    if (!embree && node->is_table() && is_source_param(*info, key)) {
      read_source_table(src, *node->as_table(), *info, key, key, keys);
      continue;
    }
    SweepKey sweep = read_sweep(src, key, *node);
    if (!embree) {
      resolve_paths(src, *info, key, sweep);
      check_value_types(src, *info, key, sweep);
    }
    for (const auto& [text, at] : sweep.values) {
      try {
        if (embree && text == "refit" && !animation)
          throw Error(
              "Embree quality 'refit' applies only to animation experiments (an [animation] table); "
              "a static experiment takes low, medium, high");
        if (embree)
          embree_params({{key, text}});
        else
          resolve_params(info->name, info->params, {{key, text}});
      } catch (const Error& e) {
        src.fail(*at, e.what());
      }
    }
    keys.push_back(std::move(sweep));
  }

  // Count before expanding: a typo can make the product astronomically large.
  uint64_t count = 1;
  std::vector<std::string> factors;
  for (const auto& k : keys) {
    count = std::min<uint64_t>(count * k.values.size(), kMaxSweepRuns + 1);
    factors.push_back(k.key + ": " + std::to_string(k.values.size()));
  }
  if (count > kMaxSweepRuns)
    src.fail(table, "builder '" + name + "' sweeps more than " + std::to_string(kMaxSweepRuns) + " runs (" +
                        join(factors, " x ") + " values)");

  // Cartesian product, last key fastest: `digit` counts in mixed radix.
  std::vector<BuilderRun> runs;
  std::vector<size_t> digit(keys.size(), 0);
  for (uint64_t i = 0; i < count; ++i) {
    BuilderRun run{name, {}};
    for (size_t k = 0; k < keys.size(); ++k)
      run.params.emplace_back(keys[k].key, keys[k].values[digit[k]].first);
    // Every embree run names its quality (medium, Embree's default, unless given), and robust only when on.
    if (embree) run.params = embree_params(run.params);
    runs.push_back(std::move(run));
    for (size_t k = keys.size(); k-- > 0;) {
      if (++digit[k] < keys[k].values.size()) break;
      digit[k] = 0;
    }
  }
  return runs;
}

void read_builders(const Source& src, const toml::table& root, ExperimentConfig& config) {
  const bool animation = config.animation.has_value();
  const auto* node = root.get("builder");
  if (!node) src.fail(1, "no [[builder]] table: at least one builder is needed");
  // Runs that would measure the same thing twice, keyed by builder and resolved values, with their line.
  std::map<std::string, std::pair<std::string, uint32_t>> seen;
  for (const toml::table* table : read_table_array(src, *node, "builder")) {
    for (auto& run : read_builder(src, *table, animation)) {
      try {
        resolve(run);
      } catch (const Error& e) {
        src.fail(*table, "builder run '" + run.label() + "': " + e.what());
      }
      if (!run.is_embree() && run.values.reads_files()) {
        // A tree file holds one tree for one scene's triangles (its header's hash); any other scene, or
        // another frame, would fail its build partway through the run.
        const std::size_t scenes = config.scenes.size() + config.optional_scenes.size();
        if (animation)
          src.fail(*table, "builder run '" + run.label() +
                               "' reads a tree file, which holds one tree for one set of triangles; an "
                               "animation experiment builds a tree for every frame: measure the file in a "
                               "static experiment");
        if (scenes > 1)
          src.fail(*table, "builder run '" + run.label() + "' reads a tree file, which fits one scene, but " +
                               "this config names " + std::to_string(scenes) +
                               " scenes (scenes and optional_scenes): give the file a config of its own "
                               "with its scene alone");
      }
      const bool traced = run.is_embree() ||
                          std::any_of(config.layouts.begin(), config.layouts.end(), [&](const LayoutSpec& l) {
                            return find_layout(l.name).arity == run.arity;
                          });
      if (!traced)
        src.fail(*table,
                 "builder '" + run.label() + "' builds " + std::to_string(run.arity) +
                     "-wide trees, but experiment.layouts has no layout for that arity (see `sahbench "
                     "list`)");
      const std::string resolved = run.name + ":" + run.params_text();
      const auto [it, inserted] = seen.emplace(resolved, std::pair{run.label(), Source::line_of(*table)});
      if (!inserted)
        src.fail(*table, "builder run '" + run.label() + "' has the same parameter values as '" +
                             it->second.first + "' (line " + std::to_string(it->second.second) + ")");
      config.builders.push_back(std::move(run));
    }
  }
  // A listed layout that no builder's trees fit would give no row at all, as a builder without a layout
  // would: both are errors. (Layouts left to their default, or beside Embree's builders alone, are not
  // checked.)
  const toml::array* listed = root["experiment"]["layouts"].as_array();
  const bool ours = std::any_of(config.builders.begin(), config.builders.end(),
                                [](const BuilderRun& run) { return !run.is_embree(); });
  if (!listed || !ours) return;  // Embree's builders alone: our layouts trace nothing either way
  for (std::size_t i = 0; i < config.layouts.size() && i < listed->size(); ++i) {
    const uint32_t arity = find_layout(config.layouts[i].name).arity;
    if (std::any_of(config.builders.begin(), config.builders.end(),
                    [&](const BuilderRun& run) { return !run.is_embree() && run.arity == arity; }))
      continue;
    const std::string what =
        arity == 2 ? std::string("a binary builder (binned_sah, sweep_sah, sbvh, ...)")
                   : "a builder of that arity (wide_collapse with arity = " + std::to_string(arity) +
                         ", for example)";
    src.fail(*listed->get(i), "experiment.layouts: \"" + config.layouts[i].text() + "\" traces " +
                                  std::to_string(arity) + "-wide trees, but no [[builder]] of this config " +
                                  "builds them, so it would give no row: add " + what +
                                  " or remove the layout");
  }
}

RaySetConfig read_ray_set(const Source& src, const toml::table& table) {
  RaySetConfig set;
  const auto* kind_node = table.get("kind");
  if (!kind_node) src.fail(table, "[[ray_set]] has no kind (kind = \"primary\", ...)");
  set.kind = read_enum(src, *kind_node, "ray_set.kind", kRayKinds);
  const std::string kind = spelling(kRayKinds, set.kind);
  set.name = kind;

  // The keys this kind reads; any other is an error rather than a setting silently ignored.
  std::vector<std::string> known = {"name", "kind"};
  if (set.kind != RayKind::kRandom) known.insert(known.end(), {"width", "height"});
  if (set.kind != RayKind::kPrimary) known.push_back("count");
  if (set.kind == RayKind::kShadow) known.insert(known.end(), {"lights", "light_source"});
  if (set.kind == RayKind::kAmbientOcclusion) known.push_back("ao_radius");
  check_keys(src, table, "[[ray_set]] of kind " + kind, known);

  if (const auto* n = table.get("name")) set.name = read_name(src, *n, "ray_set.name");
  if (const auto* n = table.get("width")) set.width = read_int(src, *n, "ray_set.width", 1, kMaxImageSide);
  if (const auto* n = table.get("height")) set.height = read_int(src, *n, "ray_set.height", 1, kMaxImageSide);
  if (set.kind == RayKind::kRandom) set.count = kDefaultRandomRays;
  if (const auto* n = table.get("count"))
    set.count = read_int(src, *n, "ray_set.count", set.kind == RayKind::kRandom ? 1 : 0, kMaxRaysPerSet);
  if (const auto* n = table.get("light_source"))
    set.light_source = read_choice(src, *n, "ray_set.light_source", {"auto", "scene"});
  if (const auto* n = table.get("lights")) {
    if (set.light_source != "auto") src.fail(*n, "ray_set.lights applies only with light_source = \"auto\"");
    set.lights = read_int(src, *n, "ray_set.lights", 1, kMaxLights);
  }
  if (const auto* n = table.get("ao_radius")) {
    if (!n->is_number()) src.fail(*n, "ray_set.ao_radius must be a number, not " + type_name(*n));
    const double radius = n->is_integer() ? double(n->as_integer()->get()) : n->as_floating_point()->get();
    if (!(radius > 0 && std::isfinite(static_cast<float>(radius))))
      src.fail(*n,
               "ray_set.ao_radius = " + param_text(src, *n, "ao_radius") + " must be positive and finite");
    set.ao_radius = static_cast<float>(radius);
  }
  return set;
}

void read_ray_sets(const Source& src, const toml::table& root, ExperimentConfig& config) {
  const auto* node = root.get("ray_set");
  if (!node) src.fail(1, "no [[ray_set]] table: at least one ray set is needed");
  for (const toml::table* table : read_table_array(src, *node, "ray_set")) {
    RaySetConfig set = read_ray_set(src, *table);
    for (const auto& other : config.ray_sets)
      if (other.name == set.name) {
        const toml::node* at = table->get("name") ? table->get("name") : table;
        src.fail(*at, "ray set name '" + set.name +
                          "' is used twice (give each [[ray_set]] its own name = \"...\")");
      }
    config.ray_sets.push_back(std::move(set));
  }
}

// A list of three numbers, each finite as a float.
std::array<float, 3> read_vec3(const Source& src, const toml::node& node, const std::string& key) {
  const std::string must = key + " must be a list of three numbers, e.g. [0.0, 1.5, -2.0]";
  const auto* list = node.as_array();
  if (!list) src.fail(node, must + ", not " + type_name(node));
  if (list->size() != 3) src.fail(node, must + ", not " + std::to_string(list->size()));
  std::array<float, 3> out{};
  for (std::size_t i = 0; i < 3; ++i) {
    const toml::node& item = *list->get(i);
    if (!item.is_number()) src.fail(item, must + ", not contain " + type_name(item));
    const double v = item.is_integer() ? double(item.as_integer()->get()) : item.as_floating_point()->get();
    if (!(std::fabs(v) <= std::numeric_limits<float>::max()))
      src.fail(item, key + ": " + param_text(src, item, key) + " is not finite as a float");
    out[i] = static_cast<float>(v);
  }
  return out;
}

// The scene a per-scene table ([[camera]], [[lights]]) names: present, a string, and a scene of the
// experiment (required or optional).
std::string read_table_scene(const Source& src, const toml::table& table, const std::string& kind,
                             const ExperimentConfig& config) {
  const auto* scene = table.get("scene");
  if (!scene) src.fail(table, "[[" + kind + "]] has no scene (scene = \"...\", as in experiment.scenes)");
  std::string name = read_string(src, *scene, kind + ".scene");
  const auto& required = config.scenes;
  const auto& optional = config.optional_scenes;
  if (std::find(required.begin(), required.end(), name) == required.end() &&
      std::find(optional.begin(), optional.end(), name) == optional.end())
    src.fail(*scene, kind + ".scene = \"" + name +
                         "\" is not a scene of this experiment (experiment.scenes or optional_scenes)");
  return name;
}

// [[camera]]: each names a scene of the experiment (checked after [experiment] is read), once.
void read_cameras(const Source& src, const toml::table& root, ExperimentConfig& config) {
  const auto* node = root.get("camera");
  if (!node) return;
  for (const toml::table* table : read_table_array(src, *node, "camera")) {
    check_keys(src, *table, "[[camera]]", {"scene", "eye", "target", "up", "fov"});
    CameraConfig camera;
    camera.scene = read_table_scene(src, *table, "camera", config);
    if (config.camera_for(camera.scene))
      src.fail(*table->get("scene"),
               "scene \"" + camera.scene + "\" has two [[camera]] tables; give one view per scene");
    for (const char* key : {"eye", "target"})
      if (!table->get(key))
        src.fail(*table, std::string("[[camera]] has no ") + key + " (" + key + " = [x, y, z])");
    camera.eye = read_vec3(src, *table->get("eye"), "camera.eye");
    camera.target = read_vec3(src, *table->get("target"), "camera.target");
    if (const auto* n = table->get("up")) camera.up = read_vec3(src, *n, "camera.up");
    if (const auto* n = table->get("fov")) {
      if (!n->is_number()) src.fail(*n, "camera.fov must be a number (degrees), not " + type_name(*n));
      const double fov = n->is_integer() ? double(n->as_integer()->get()) : n->as_floating_point()->get();
      if (!(fov > 0.0 && fov < 180.0))
        src.fail(*n, "camera.fov = " + param_text(src, *n, "fov") + " degrees must be in (0, 180)");
      camera.fov = static_cast<float>(fov);
    }
    // The view as a whole (target at the eye, up zero or along the view): the line of the table.
    try {
      to_camera(camera);
    } catch (const Error& e) {
      src.fail(*table, std::string("[[camera]] for \"") + camera.scene + "\": " + e.what());
    }
    config.cameras.push_back(std::move(camera));
  }
}

// [[lights]]: each names a scene of the experiment, once, and some shadow set takes the scene's lights.
void read_lights(const Source& src, const toml::table& root, ExperimentConfig& config) {
  const auto* node = root.get("lights");
  if (!node) return;
  const bool used = std::any_of(config.ray_sets.begin(), config.ray_sets.end(), [](const RaySetConfig& rs) {
    return rs.kind == RayKind::kShadow && rs.light_source == "scene";
  });
  for (const toml::table* table : read_table_array(src, *node, "lights")) {
    check_keys(src, *table, "[[lights]]", {"scene", "positions"});
    if (!used)
      src.fail(*table,
               "[[lights]] is for shadow sets with light_source = \"scene\", and no [[ray_set]] has one; "
               "add one, or remove the table");
    LightsConfig lights;
    lights.scene = read_table_scene(src, *table, "lights", config);
    if (config.lights_for(lights.scene))
      src.fail(*table->get("scene"),
               "scene \"" + lights.scene + "\" has two [[lights]] tables; list all its lights in one");
    const auto* positions = table->get("positions");
    const std::string must = "lights.positions must be a list of 1 to " + std::to_string(kMaxLights) +
                             " points, e.g. [[0.0, 2.0, 0.5]]";
    if (!positions) src.fail(*table, "[[lights]] has no positions (positions = [[x, y, z], ...])");
    const auto* list = positions->as_array();
    if (!list) src.fail(*positions, must + ", not " + type_name(*positions));
    if (list->empty() || list->size() > kMaxLights)
      src.fail(*positions, must + ", not " + std::to_string(list->size()));
    for (std::size_t i = 0; i < list->size(); ++i)
      lights.positions.push_back(
          read_vec3(src, *list->get(i), "lights.positions[" + std::to_string(i) + "]"));
    config.lights.push_back(std::move(lights));
  }
}

}  // namespace

const CameraConfig* ExperimentConfig::camera_for(std::string_view scene) const {
  for (const auto& camera : cameras)
    if (camera.scene == scene) return &camera;
  return nullptr;
}

const LightsConfig* ExperimentConfig::lights_for(std::string_view scene) const {
  for (const auto& l : lights)
    if (l.scene == scene) return &l;
  return nullptr;
}

BuilderRun parse_builder_run(std::string_view text) {
  BuilderRun run;
  const auto colon = text.find(':');
  run.name = std::string(text.substr(0, colon));
  if (run.name.empty()) throw Error("builder '" + std::string(text) + "' has no name");
  std::string_view rest = colon == std::string_view::npos ? "" : text.substr(colon + 1);
  // "file:PATH" is short for "file:path=PATH", and "file:PATH,c_trav=2" for "file:path=PATH,c_trav=2".
  if (run.name == "file" && !rest.empty()) {
    const std::string_view first = rest.substr(0, rest.find(','));
    if (first.find('=') == std::string_view::npos) {
      run.params.emplace_back("path", std::string(first));
      rest = first.size() == rest.size() ? std::string_view{} : rest.substr(first.size() + 1);
    }
  }
  while (!rest.empty()) {
    const auto comma = rest.find(',');
    run.params.push_back(parse_override(rest.substr(0, comma)));
    rest = comma == std::string_view::npos ? "" : rest.substr(comma + 1);
  }
  for (const char* quality : {"low", "medium", "high"})
    if (run.name == std::string("embree_") + quality) {
      if (!run.params.empty())
        throw Error("builder '" + std::string(text) + "': " + run.name + " takes no parameters");
      run.name = "embree";
      run.params = {{"quality", quality}};
    }
  if (!run.is_embree()) return run;
  try {
    run.params = embree_params(run.params);
  } catch (const Error& e) {
    throw Error("builder '" + std::string(text) + "': " + e.what());
  }
  return run;
}

void resolve(BuilderRun& run) {
  if (run.is_embree()) {
    for (const auto& [key, value] : embree_params(run.params)) {
      if (key == "quality") run.quality = parse_embree_quality(value);
      if (key == "robust") run.robust = parse_embree_robust(value);
    }
    return;
  }
  run.info = &find_builder(run.name);
  run.values = resolve_params(run.info->name, run.info->params, run.params);
  if (run.info->check) run.info->check(run.values);
  run.arity = run.info->arity ? run.info->arity(run.values) : 2;
}

void require_resolved(const BuilderRun& run) {
  // Embree's: what its parameters say is what resolve() set (the defaults need no resolving).
  const bool resolved = run.is_embree() ? run.params_text() == "quality=" + to_string(run.quality) +
                                                                   (run.robust ? ";robust=1" : "")
                                        : run.info != nullptr;
  if (!resolved) throw Error("builder run '" + run.label() + "' was not resolved against the registry");
}

void require_layout_of_arity(const BuilderRun& run, const LayoutSpec& layout) {
  const uint32_t arity = find_layout(layout.name).arity;
  if (run.is_embree() || arity == run.arity) return;
  std::string instead;
  for (const auto& l : layouts())
    if (l.arity == run.arity) instead += (instead.empty() ? "" : " or ") + l.name;
  std::string message = "--layout '" + layout.text() + "' traces " + std::to_string(arity) +
                        "-wide trees, but " + run.label() + " builds " + std::to_string(run.arity) +
                        "-wide ones: use " + (instead.empty() ? "another builder" : instead);
  if (arity > 2)
    message += ", or --builder wide_collapse:arity=" + std::to_string(arity) + " for a tree of its arity";
  throw Error(message);
}

std::string default_layout(const BuilderRun& run) {
  for (const auto& l : layouts())
    if (l.arity == run.arity) return l.name;
  throw Error("no layout traces the " + std::to_string(run.arity) + "-wide trees of " + run.label());
}

std::string BuilderRun::params_text() const {
  if (!is_embree()) return values.to_string();
  std::string quality = "medium", robust;
  for (const auto& [key, value] : params) {
    if (key == "quality") quality = value;
    if (key == "robust" && (value == "1" || value == "true")) robust = ";robust=1";
  }
  return "quality=" + quality + robust;
}

std::string BuilderRun::label() const {
  if (params.empty()) return name;
  std::string out = name + "[";
  for (size_t i = 0; i < params.size(); ++i) {
    const auto& [key, value] = params[i];
    // Embree's robust mode reads as a word: "embree[quality=medium,robust]".
    const bool flag = is_embree() && key == "robust" && value == "1";
    out += (i ? "," : "") + key + (flag ? "" : "=" + value);
  }
  return out + "]";
}

Camera to_camera(const CameraConfig& camera) {
  auto vec = [](const std::array<float, 3>& a) { return Vec3{a[0], a[1], a[2]}; };
  return look_at_camera(vec(camera.eye), vec(camera.target), vec(camera.up), camera.fov);
}

std::vector<Vec3> to_lights(const LightsConfig& lights) {
  std::vector<Vec3> out;
  for (const auto& p : lights.positions) out.push_back({p[0], p[1], p[2]});
  return out;
}

std::string to_string(RayKind kind) {
  return spelling(kRayKinds, kind);
}

std::optional<RayKind> parse_ray_kind(std::string_view name) {
  for (const auto& [text, kind] : kRayKinds)
    if (text == name) return kind;
  return std::nullopt;
}

std::string to_string(ReferencePolicy policy) {
  return spelling(kReferencePolicies, policy);
}

ExperimentConfig load_experiment_config(const std::filesystem::path& path) {
  return parse_experiment_config(read_text_file(path, "experiment config"), path.string());
}

ExperimentConfig parse_experiment_config(std::string_view toml_text, const std::string& source_name) {
  const Source src{source_name};
  const toml::table root = parse_toml(toml_text, source_name);
  check_keys(src, root, "the top level",
             {"experiment", "repetitions", "builder", "ray_set", "camera", "lights", "animation"});

  ExperimentConfig config;
  config.path = source_name;
  read_experiment(src, root, config);
  if (const auto* node = root.get("repetitions")) read_repetitions(src, *node, config.reps);
  // Before the builders: Embree's "refit" quality is valid only in an animation experiment.
  if (const auto* node = root.get("animation")) read_animation(src, *node, config);
  read_builders(src, root, config);
  read_ray_sets(src, root, config);
  read_cameras(src, root, config);
  read_lights(src, root, config);
  return config;
}

}  // namespace sahbench
