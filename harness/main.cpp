// The sahbench command line. Library code throws sahbench::Error; this is the one place that prints
// errors and chooses exit codes: 0 success, 1 a failed check (invalid tree), 2 bad input.

#include <CLI/CLI.hpp>

#include <iostream>

#include "builders/params.h"
#include "core/error.h"
#include "harness/build_command.h"
#include "harness/list_command.h"

int main(int argc, char** argv) {
  using namespace sahbench;
  CLI::App app{"sahbench: benchmark and research harness for SAH BVH builders"};
  app.require_subcommand(1);

  BuildCommandOptions build;
  std::vector<std::string> params;
  auto* build_cmd = app.add_subcommand("build", "Load a scene, build, validate, and print build time and tree statistics");
  build_cmd->add_option("--scene", build.scene, "scene file, shared-scene name, or proc:KIND[:key=value,...]")->required();
  build_cmd->add_option("--builder", build.builders,
                        "builder NAME or NAME:key=value,...; repeatable; embree_low|embree_medium|embree_high "
                        "for Embree's rtcCommitScene")->required();
  build_cmd->add_option("--param", params, "key=value for every one of our builders; repeatable");
  build_cmd->add_option("--threads", build.threads, "thread counts, e.g. 1,2")->delimiter(',');
  build_cmd->add_option("--reps", build.reps, "timed repetitions (median reported)")->capture_default_str();
  build_cmd->add_option("--warmup", build.warmup, "untimed builds first")->capture_default_str();

  auto* list_cmd = app.add_subcommand("list", "Builders and their parameters, procedural scene kinds, shared scenes found");
  auto* list_scenes_cmd = app.add_subcommand("list-scenes", "Names of the shared scenes found, one per line");

  CLI11_PARSE(app, argc, argv);
  try {
    if (*build_cmd) {
      for (const auto& p : params) build.params.push_back(parse_override(p));
      return run_build_command(build, std::cout, std::cerr);
    }
    if (*list_cmd) print_catalogue(std::cout);
    if (*list_scenes_cmd) print_scene_names(std::cout);
  } catch (const Error& e) {
    std::cerr << "sahbench: error: " << e.what() << "\n";
    return 2;
  } catch (const std::exception& e) {
    std::cerr << "sahbench: internal error: " << e.what() << "\n";
    return 3;
  }
  return 0;
}
