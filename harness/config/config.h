#pragma once
// Experiment configs: one TOML file says which scenes, builders (with parameter sweeps), layouts, ray
// sets, thread counts and repetitions an experiment runs, and where its CSV goes. Everything is checked
// when the file is read, so that a typo fails at once, naming file, line, key and value, rather than an
// hour into a run.
//
// A complete example (every key; the values shown for optional keys are their defaults unless noted):
//
//   [experiment]
//   name = "default"                  # required: letters, digits, '-', '_'
//   output = "results/default.csv"    # default "results/<name>.csv", relative to the current directory
//   seed = 1                          # seeds every ray set (proc:KIND:seed=N seeds a scene)
//   threads = [1, 2]                  # an integer or a list (default 1)
//   scenes = ["proc:soup:tris=100k"]  # required scenes: a missing one is an error at run time
//   optional_scenes = ["crytek_sponza", "stanford_bunny"]   # skipped with a message when not found
//   layouts = ["bvh2"]                # default ["bvh2"]
//   reference = "auto"                # auto | embree | brute_force | none
//   brute_force_max_triangles = 20000 # auto only: brute force up to this many triangles, else Embree
//   epo = false                       # true: each tree of ours also gets its EPO cost (core/epo.h) in
//                                     # epo_cost and sah_epo_cost; untimed, but a walk of the tree per
//                                     # triangle, so off unless a config studies tree quality
//
//   [repetitions]                     # timed runs >= 1, warm-up runs >= 0
//   build = 5
//   build_warmup = 1
//   trace = 5
//   trace_warmup = 1
//   interleave = true                 # static runs: trace repetitions of a scene's cells taken in turns
//
//   [animation]                       # optional: makes this an animation experiment (see below)
//   frames = 10                       # frames evenly spaced over each scene's animation (default 10)
//   # times = [0.0, 0.5, 1.0]         # instead of frames: these times in seconds, increasing
//
//   [[builder]]                       # one table per builder; at least one
//   name = "binned_sah"               # a registered builder, or "embree" (rtcCommitScene's own BVH)
//   bins = [8, 16, 32]                # any parameter given as a list expands into a sweep
//   max_leaf = 8                      # numbers as numbers (a quoted "8" is an error), names and paths
//                                     # as strings, booleans (true = 1) for 0/1 switches only
//
//   [[builder]]
//   name = "reinsert"                 # a pass: `source` names the binary builder or pass it takes its
//   iterations = 4                    # tree from, as a table (or inline: source = { name = ..., ... })
//   [builder.source]                  # with that builder's own parameters, nested again for its own
//   name = "treelet"                  # source; lists sweep there as here. `source = "treelet"` alone
//   source = { name = "binned_sah", max_leaf = 4 }   # takes that builder's defaults.
//                                     # The command line spells the same chain with dotted keys:
//                                     #   reinsert:iterations=4,source=treelet,source.source=binned_sah,
//                                     #   source.source.max_leaf=4
//                                     # builder_params records it resolved, each source's values in
//                                     # parentheses: source=treelet(source=binned_sah(...);...);iterations=4
//
//   # [[builder]]                     # a tree read from a tree file (docs/tree_format.md), for a file
//   # name = "file"                   # that exists (its header is read with the config); a relative
//   # path = "trees/bunny.sbt"        # path is relative to this config's folder
//
//   [[builder]]
//   name = "embree"
//   quality = ["medium", "high"]      # embree takes quality: low | medium (default) | high, and refit
//                                     # in animation experiments; and robust:
//   robust = false                    # true: Embree's robust mode (RTC_SCENE_FLAG_ROBUST, which also
//                                     # selects its watertight triangle test); [false, true]: both
//
//   [[ray_set]]                       # one table per ray set; at least one
//   kind = "primary"                  # primary | shadow | diffuse | ao | random
//   width = 512                       # primary image; secondary sets start from its hits
//   height = 512
//
//   [[ray_set]]
//   name = "shadow_scene"             # default: the kind's name; names must be unique
//   kind = "shadow"
//   light_source = "scene"            # auto (place `lights` point lights, default) | scene
//   count = 100000                    # 0 (default): one ray per primary hit; else that many, cycling
//
//   [[ray_set]]
//   kind = "ao"
//   ao_radius = 0.05                  # ray length as a fraction of the scene box diagonal
//
//   [[ray_set]]
//   kind = "random"
//   count = 262144                    # random rays to generate
//
//   [[camera]]                        # optional, at most one per scene: the view of its primary rays, and
//   scene = "crytek_sponza"           # so of its secondary sets; replaces the file's camera and the
//   eye = [-115.0, 18.0, -4.0]        # automatic framing. scene: as spelled in scenes or optional_scenes;
//   target = [100.0, 40.0, 4.0]       # eye and target in the scene's units, target at the image centre
//   up = [0, 1, 0]                    # default; not parallel to target - eye (a view that cannot be
//                                     # made, e.g. target = eye, is an error at the [[camera]] line)
//   fov = 45                          # vertical field of view in degrees, in (0, 180); default 45
//
//   [[lights]]                        # optional, at most one per scene: point lights for its shadow sets
//   scene = "crytek_sponza"           # with light_source = "scene", in place of the file's own lights
//   positions = [[0.0, 120.0, 0.0], [60.0, 100.0, -10.0]]  # in the scene's units; 1 to kMaxLights
//
// Keys by ray-set kind (any other key is an error, so that no setting is silently ignored):
//   all: name, kind;  primary, shadow, diffuse, ao: width, height;  shadow, diffuse, ao, random: count;
//   shadow: light_source, and lights when light_source = "auto";  ao: ao_radius.
//
// Sweeps: the parameters of a [[builder]] given as lists expand into their cartesian product, with the
// key written last varying fastest; runs keep file order across [[builder]] tables. Two runs that
// resolve to the same builder and parameter values (e.g. `bins = 16` next to the default) are an error,
// as are sweeps of more than kMaxSweepRuns runs.
//
// Animation experiments (an [animation] table; harness/run/animation_runner.h): every scene that is animated
// (a glTF file with an animation, proc:wave) is measured frame by frame; static scenes are skipped with
// a message. Each of our builders gives two rows per frame and cell: the tree built on the first frame
// and refitted to this one (builder "refit(NAME)"), and a fresh build (builder NAME); `embree` with
// quality refit is Embree's own refit (a dynamic scene recommitted per frame), other qualities rebuild.
//
// Every error is a sahbench::Error whose message starts with "<file>:<line>:" (for a key, the line of
// its value; for a missing key, the line of its table; for a missing table, line 1).

#include <array>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "builders/params.h"
#include "builders/registry.h"
#include "harness/embree/embree_scene.h"
#include "scenes/scene.h"
#include "traversal/layout.h"

namespace sahbench {

/// Most runs one [[builder]] table may expand into: a guard against a typo such as `bins = [8, 16, ...]`
/// pasted into every key. 10,000 runs is already days of benchmarking on one scene.
inline constexpr uint64_t kMaxSweepRuns = 10000;

/// One builder with one parameter assignment, after sweep expansion.
struct BuilderRun {
  /// A registered builder (find_builder) or "embree" (Embree's own rtcCommitScene BVH).
  std::string name;
  /// key=value strings as the user set them, in file order (integers without a decimal point, floats in
  /// shortest round-trip form, booleans as 1/0). For "embree" always {"quality", low|medium|high},
  /// "medium" (Embree's default) when the config does not say, then {"robust", "1"} in robust mode only:
  /// Embree's default mode is written as it was before robust mode was a row, so that its cells keep
  /// their names and builder_params text (the CI baseline's).
  ParamOverrides params;
  /// Our builder's registry entry and every one of its parameters' values, set by resolve(): once, where
  /// the run is read. Null and empty for Embree, and before resolve().
  const BuilderInfo* info = nullptr;
  ParamSet values{};
  /// Also set by resolve(): ours, the arity of its trees (traced only with layouts of that arity);
  /// Embree's, its build quality and whether its scene is robust (RTC_SCENE_FLAG_ROBUST).
  uint32_t arity = 2;
  EmbreeQuality quality = EmbreeQuality::kMedium;
  bool robust = false;

  bool is_embree() const { return name == "embree"; }
  /// Embree's scene flags for this run (embree_scene.h).
  EmbreeSceneOptions embree_options() const {
    EmbreeSceneOptions options;
    options.robust = robust;
    return options;
  }
  /// The CSV's builder_params column: our resolved values (ParamSet::to_string), or Embree's
  /// "quality=Q", with ";robust=1" after it in robust mode.
  std::string params_text() const;
  /// "binned_sah[bins=8,max_leaf=4]", "embree[quality=medium]" or "embree[quality=medium,robust]"; the
  /// name alone without parameters.
  std::string label() const;
  /// The same run: the same name and parameters as set (the resolved values follow from them).
  bool operator==(const BuilderRun& o) const { return name == o.name && params == o.params; }
};

/// Resolves a builder run: ours against the registry (`info`, `values` by resolve_params, then the
/// builder's own check, and `arity`), Embree's to its `quality` and `robust`. An unknown builder,
/// parameter or value is an Error naming it.
void resolve(BuilderRun& run);

/// An Error naming the run unless it went through resolve(): a config built in code rather than read
/// must resolve its runs before a runner sees them.
void require_resolved(const BuilderRun& run);

/// A layout traces the trees of its own arity: `sahbench run` pairs each builder run only with those, and
/// `trace` and `image` keep the same rule. An Error naming the layout, the builder and what to use instead
/// where `layout` is of another arity than `run`'s (resolved) trees.
void require_layout_of_arity(const BuilderRun& run, const LayoutSpec& layout);

/// The layout `trace` and `image` use when none is given: the first registered layout of the arity of
/// `run`'s (resolved, ours) trees, bvh2 for binary ones.
std::string default_layout(const BuilderRun& run);

/// A builder run as the command line writes it: "NAME" or "NAME:key=value,key=value", for one of our
/// builders or Embree's own BVH ("embree:quality=high", "embree:quality=medium,robust=1"; "embree_low",
/// "embree_medium" and "embree_high" are short for the three qualities in Embree's default mode).
/// Embree's run has its parameters as a config's (quality, medium by default, then robust=1 in robust
/// mode; robust takes 1, 0, true or false); "file:PATH" is short for "file:path=PATH" (PATH as given,
/// relative to the current directory); malformed text or an unknown Embree parameter or value is an
/// Error naming it. Our builders' names and parameters are checked where they are resolved against the
/// registry.
BuilderRun parse_builder_run(std::string_view text);

enum class RayKind { kPrimary, kShadow, kDiffuse, kAmbientOcclusion, kRandom };

/// "primary", "shadow", "diffuse", "ao", "random": the config's spelling, and the CSV's.
std::string to_string(RayKind kind);
/// The inverse of to_string; nullopt for a name that is no ray kind.
std::optional<RayKind> parse_ray_kind(std::string_view name);

/// Random ray sets generate this many rays unless `count` says otherwise: as many as a 512x512 primary
/// image, so that random and primary sets of the default size weigh the same.
inline constexpr uint32_t kDefaultRandomRays = 262144;
/// Largest primary image side: a 16384^2 image is 268M rays (over 8 GiB of rays); larger is a typo.
inline constexpr uint32_t kMaxImageSide = 16384;
/// Most rays of one set (`count`): as many as the largest image.
inline constexpr uint32_t kMaxRaysPerSet = kMaxImageSide * kMaxImageSide;
/// Most generated lights of a shadow set: each shadow ray goes to one of them, so more lights than rays
/// leave lights unused, and their set-up is paid for every ray set.
inline constexpr uint32_t kMaxLights = 65536;

struct RaySetConfig {
  std::string name;  ///< unique; defaults to the kind as the config spells it ("primary", ..., "ao")
  RayKind kind = RayKind::kPrimary;
  /// Primary image; secondary sets are generated from the primary hits of this image.
  uint32_t width = 512, height = 512;
  /// random: rays to generate (kDefaultRandomRays unless set); others: 0 = one per primary hit, else that
  /// many (cycling over the hits). Always 0 for primary.
  uint32_t count = 0;
  uint32_t lights = 4;                ///< shadow with light_source "auto": automatic point lights
  std::string light_source = "auto";  ///< shadow: "auto" (place `lights` lights) or "scene" (its own)
  float ao_radius = 0.05f;            ///< ao: ray length as a fraction of the scene box diagonal

  bool operator==(const RaySetConfig&) const = default;
};

/// A view for one scene's primary rays ([[camera]] above), and so for every secondary set, which start at
/// the primary hits: it replaces the file's camera and the automatic framing (scenes/camera.h:
/// look_at_camera).
struct CameraConfig {
  std::string scene;  ///< as spelled in experiment.scenes or experiment.optional_scenes
  std::array<float, 3> eye{}, target{};
  std::array<float, 3> up{0.0f, 1.0f, 0.0f};
  float fov = 45.0f;  ///< vertical field of view in degrees

  bool operator==(const CameraConfig&) const = default;
};

/// look_at_camera (scenes/camera.h) of a [[camera]]: an Error where the view cannot be made.
Camera to_camera(const CameraConfig& camera);

/// Point lights for one scene's shadow sets with light_source = "scene" ([[lights]] above): they replace
/// the file's own lights, as a [[camera]] replaces its view, so that a scene without lights of its own,
/// or whose automatic lights fall inside it (ray_sets.h: enclosed), gets the lights a renderer would use.
struct LightsConfig {
  std::string scene;  ///< as spelled in experiment.scenes or experiment.optional_scenes
  std::vector<std::array<float, 3>> positions;

  bool operator==(const LightsConfig&) const = default;
};

/// The positions of a [[lights]] as the scene's lights.
std::vector<Vec3> to_lights(const LightsConfig& lights);

/// Most frames an animation experiment may sample: a guard against a typo, as every frame is a full set
/// of builds and traces per builder (10,000 frames are close to three minutes of animation at 60 Hz).
inline constexpr uint32_t kMaxFrames = 10000;

/// The frames of an animation experiment: `frames` times evenly spaced over each scene's animation
/// (AnimatedScene::frame_times), or the explicit `times` (seconds, increasing; then frames is their count).
struct AnimationConfig {
  uint32_t frames = 10;
  std::vector<double> times;
  bool operator==(const AnimationConfig&) const = default;
};

/// Timed repetitions (at least 1) and untimed warm-up runs before them (at least 0).
struct Repetitions {
  int build = 5, build_warmup = 1, trace = 5, trace_warmup = 1;
  /// Static runs: every cell of a scene and thread count (Embree's included) is built and compiled
  /// first, then traced one repetition at a time in turns, so that a slow spell of a noisy machine falls
  /// on every cell alike and ratios between cells hold; rows are written once the scene's cells are
  /// timed. false: each cell's repetitions back to back, its row written at once, one tree in memory.
  bool interleave = true;
  bool operator==(const Repetitions&) const = default;
};

/// Which reference every cell's hits are checked against. kAuto: brute force up to
/// ExperimentConfig::brute_force_max_triangles triangles, Embree above.
enum class ReferencePolicy { kAuto, kEmbree, kBruteForce, kNone };

/// "auto", "embree", "brute_force", "none": the config's spelling.
std::string to_string(ReferencePolicy policy);

struct ExperimentConfig {
  std::filesystem::path path;  ///< the file read (or the source name given to parse_experiment_config)
  std::string name;
  /// Default "results/<name>.csv"; kept as written, so a relative path is relative to the current directory.
  std::filesystem::path output;
  uint64_t seed = 1;
  std::vector<int> threads{1};
  std::vector<std::string> scenes;           ///< required scenes (a missing one is an error at run time)
  std::vector<std::string> optional_scenes;  ///< skipped with a message when not found (the shared scenes)
  /// Expanded sweeps, in file order; within a sweep, the cartesian product with the last key fastest.
  std::vector<BuilderRun> builders;
  std::vector<LayoutSpec> layouts{
      LayoutSpec{"bvh2", KernelVariant{}, KernelIsa::kAuto}};  ///< parsed; none twice
  std::vector<RaySetConfig> ray_sets;
  /// At most one per scene, each naming a scene of this experiment.
  std::vector<CameraConfig> cameras;
  /// At most one per scene, each naming a scene of this experiment; only with a light_source = "scene" set.
  std::vector<LightsConfig> lights;
  Repetitions reps;
  ReferencePolicy reference = ReferencePolicy::kAuto;
  uint64_t brute_force_max_triangles = 20000;
  /// experiment.epo: compute every tree's EPO cost (core/epo.h) for its rows.
  bool epo = false;
  /// Present for an animation experiment ([animation] table).
  std::optional<AnimationConfig> animation;

  /// The [[camera]] for `scene` (as spelled in scenes or optional_scenes), or null.
  const CameraConfig* camera_for(std::string_view scene) const;
  /// The [[lights]] for `scene`, or null.
  const LightsConfig* lights_for(std::string_view scene) const;

  bool operator==(const ExperimentConfig&) const = default;
};

/// Reads and checks the config at `path`; an unreadable file or an invalid config is an Error.
ExperimentConfig load_experiment_config(const std::filesystem::path& path);

/// Checks and expands the config in `toml_text`; `source_name` stands for the file in messages and in
/// ExperimentConfig::path.
ExperimentConfig parse_experiment_config(std::string_view toml_text, const std::string& source_name);

}  // namespace sahbench
