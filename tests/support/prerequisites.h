#pragma once
// What a test needs from its surroundings (a shared scene, kernels for an instruction set) and what it does
// when that is missing: locally a skip that says why, so that a machine without the scenes or without
// AVX-512 still runs the rest; under CI=true a failure, so that a CI job cannot pass without running the
// test. An ISA the CPU lacks is a skip even under CI=true (no build can run it there); one the CPU has but
// this build left out is a failure there.
//
// Use in a test body:
//   SAHBENCH_REQUIRE_SHARED_SCENE("crytek_sponza");
// and in a test that loops over parts (scenes, ISAs):
//   test::Skips skips;
//   for (KernelIsa isa : ...) { if (!skips.have_isa(isa)) continue; ... }
//   SAHBENCH_REPORT_SKIPS(skips);

#include <gtest/gtest.h>

#include <cstdlib>
#include <iostream>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "scenes/scene_path.h"
#include "traversal/kernel_variant.h"

namespace sahbench::test {

/// Whether the environment variable CI is "true", as CI services set it.
inline bool in_ci() {
  const char* ci = std::getenv("CI");
  return ci != nullptr && std::string_view(ci) == "true";
}

/// Why the shared scene `name` is not there, or nullopt when find_scene_file finds it. Under CI=true a
/// missing scene is also a failure of the running test.
inline std::optional<std::string> missing_shared_scene(std::string_view name) {
  if (find_scene_file(name)) return std::nullopt;
  // Appended piece by piece: "literal" + std::string(...) trips GCC 12's -Wrestrict false positive.
  std::string why = "shared scene '";
  why += name;
  why += "' not found; looked in:";
  for (const auto& dir : scene_search_path_candidates()) {
    why += ' ';
    why += dir.string();
  }
  if (in_ci()) ADD_FAILURE() << why << " (CI=true: the shared scenes must be present)";
  return why;
}

/// Why kernels for `isa` cannot run here, or nullopt when they can. Under CI=true an ISA that the CPU has
/// but this build did not compile is also a failure of the running test.
inline std::optional<std::string> missing_kernel_isa(KernelIsa isa) {
  if (kernel_isa_available(isa)) return std::nullopt;
  const std::string name(to_string(isa));
  if (!cpu_supports_kernel_isa(isa)) return name + " kernels: the CPU lacks " + name;
  const std::string why = name + " kernels: not compiled into this build, though the CPU has " + name;
  if (in_ci()) ADD_FAILURE() << why << " (CI=true)";
  return why;
}

/// The parts of one test that could run (have_scene or have_isa said yes) and those that could not, and why.
class Skips {
 public:
  /// Whether the shared scene `name` is there; if not, records why (a failure under CI=true).
  bool have_scene(std::string_view name) { return keep(missing_shared_scene(name)); }
  /// Whether kernels for `isa` run here; if not, records why (a failure under CI=true where the CPU has it).
  bool have_isa(KernelIsa isa) { return keep(missing_kernel_isa(isa)); }
  /// Whether parts were asked for and none could run.
  bool none_ran() const { return ran_ == 0 && any(); }
  bool any() const { return !reasons_.empty(); }
  /// The reasons, one per skipped part, separated by "; ".
  std::string text() const {
    std::string out;
    for (const auto& r : reasons_) out += (out.empty() ? "" : "; ") + r;
    return out;
  }

 private:
  bool keep(std::optional<std::string> why) {
    if (!why) {
      ++ran_;
      return true;
    }
    for (const auto& r : reasons_)
      if (r == *why) return false;
    reasons_.push_back(std::move(*why));
    return false;
  }
  std::vector<std::string> reasons_;
  int ran_ = 0;
};

/// Writes the skipped parts, if any, as the test property "skipped" (in the XML report) and on stdout:
/// a test that ran some parts passes, and says which it left out.
inline void report_partial(const Skips& skips) {
  if (!skips.any()) return;
  ::testing::Test::RecordProperty("skipped", skips.text());
  std::cout << "[ PARTIAL  ] skipped " << skips.text() << "\n";
}

}  // namespace sahbench::test

/// Ends the test with a skip naming the reason when the shared scene `name` is missing (a failure under
/// CI=true).
#define SAHBENCH_REQUIRE_SHARED_SCENE(name)                                                            \
  do {                                                                                                 \
    if (const auto missing_ = ::sahbench::test::missing_shared_scene(name)) GTEST_SKIP() << *missing_; \
  } while (0)

/// At the end of a test that loops over parts: a skip when none could run, else report_partial.
#define SAHBENCH_REPORT_SKIPS(skips)                                           \
  do {                                                                         \
    if ((skips).none_ran()) GTEST_SKIP() << "nothing ran: " << (skips).text(); \
    ::sahbench::test::report_partial(skips);                                   \
  } while (0)
