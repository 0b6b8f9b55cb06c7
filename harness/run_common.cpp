#include "harness/run_common.h"

#include <fmt/format.h>

#include <cmath>
#include <ctime>
#include <ostream>

#include "harness/csv.h"
#include "harness/embree_scene.h"
#include "harness/embree_trace.h"
#include "harness/runner.h"
#include "scenes/load.h"
#include "scenes/proc_spec.h"
#include "scenes/procedural.h"
#include "scenes/scene_path.h"

namespace sahbench {

std::vector<EmbreeLayout> supported_embree_layouts(std::ostream& log) {
  std::vector<EmbreeLayout> out;
  EmbreeDevice probe(1);
  for (const auto& l : kEmbreeLayouts) {
    if (l.packet_width == 1 || embree_packets_supported(probe, l.packet_width)) {
      out.push_back(l);
    } else {
      log << fmt::format("skipping layout {}: Embree has no native {}-wide packets on this CPU\n", l.name,
                         l.packet_width);
    }
  }
  return out;
}

std::string now_stamp() {
  const std::time_t t = std::time(nullptr);
  std::tm tm{};
  gmtime_r(&t, &tm);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y%m%d-%H%M%S", &tm);
  return buf;
}

std::string format_duration(double seconds) {
  const auto s = static_cast<long>(std::lround(seconds));
  return s >= 60 ? fmt::format("{}m{:02}s", s / 60, s % 60) : fmt::format("{}s", s);
}

std::vector<std::string> scenes_to_run(const ExperimentConfig& cfg, std::ostream& log) {
  for (const auto& name : cfg.scenes) {
    if (is_procedural_spec(name)) {
      parse_proc_spec(name, procedural_kinds());
    } else if (!std::filesystem::is_regular_file(name) && !find_scene_file(name)) {
      load_scene(name);  // throws the loader's error, which names the scene and the search path
    }
  }
  std::vector<std::string> out = cfg.scenes;
  for (const auto& name : cfg.optional_scenes) {
    if (find_scene_file(name)) {
      out.push_back(name);
    } else {
      log << fmt::format("skipping optional scene '{}': not found on the scene search path\n", name);
    }
  }
  return out;
}

std::set<std::string> finished_cells(const std::filesystem::path& output, const ExperimentConfig& cfg,
                                     std::string& run_id, std::ostream& log) {
  std::set<std::string> finished;
  for (const auto& row : read_csv(output)) {
    finished.insert(cell_key(row.at("scene"), row.at("builder"), row.at("builder_params"), row.at("layout"),
                             std::stoi(row.at("threads")), row.at("ray_set"), std::stoi(row.at("frame"))));
    if (row.at("config") == cfg.path.string()) run_id = row.at("run_id");
  }
  log << fmt::format("resume: {} finished cells in {}\n", finished.size(), output.string());
  return finished;
}

}  // namespace sahbench
