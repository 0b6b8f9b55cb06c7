#include "harness/run/environment.h"

#include <embree3/rtcore.h>

#include <fstream>

namespace sahbench {
namespace {

// The model name with its family and model numbers: the name alone ("AMD EPYC" in a VM) does not tell
// one generation from another, and the kernels' speeds differ between them.
std::string cpu_model() {
  std::ifstream in("/proc/cpuinfo");
  std::string line, name, family, model;
  auto value = [&] {
    const auto colon = line.find(':');
    if (colon == std::string::npos) return std::string();
    const auto start = line.find_first_not_of(" \t", colon + 1);
    return start == std::string::npos ? std::string() : line.substr(start);
  };
  while (std::getline(in, line) && !line.empty()) {
    if (line.rfind("model name", 0) == 0) name = value();
    if (line.rfind("cpu family", 0) == 0) family = value();
    if (line.rfind("model", 0) == 0 && line.rfind("model name", 0) != 0) model = value();
  }
  if (name.empty()) return "unknown";
  if (family.empty() || model.empty()) return name;
  return name + " (family " + family + " model " + model + ")";
}

// The ISA the compiler was allowed to use for our code (set by -march). Runtime dispatch between
// kernels of several ISAs is the wide-BVH issue's; until then this is what every kernel ran with.
std::string compiled_isa() {
#if defined(__AVX512F__) && defined(__AVX512VL__)
  return "avx512";
#elif defined(__AVX2__)
  return "avx2";
#elif defined(__AVX__)
  return "avx";
#elif defined(__SSE4_2__)
  return "sse4.2";
#else
  return "sse2";
#endif
}

std::string compiler() {
#if defined(__clang__)
  return "clang " __clang_version__;
#elif defined(__GNUC__)
  return "gcc " + std::to_string(__GNUC__) + "." + std::to_string(__GNUC_MINOR__) + "." +
         std::to_string(__GNUC_PATCHLEVEL__);
#else
  return "unknown";
#endif
}

std::string embree_version() {
  return RTC_VERSION_STRING;
}

}  // namespace

Environment current_environment() {
  return {build_git_commit(), cpu_model(), compiled_isa(), compiler(), "embree " + embree_version()};
}

}  // namespace sahbench
