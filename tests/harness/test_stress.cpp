// The stress suite: its error metrics on hand-made answers, the time bound on builds, the generators'
// promises, the config's checks, and a reduced suite end to end with its guarantees asserted: every
// builder terminates with a valid tree and no NaN bounds, the default kernels (watertight triangle test,
// conservative box test) neither miss nor leak on the closed cases, invalid triangles are removed and
// counted, nothing crashes; and the report's stress tables.

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <cstring>
#include <filesystem>
#include <limits>
#include <set>
#include <sstream>
#include <thread>

#include "builders/registry.h"
#include "core/error.h"
#include "harness/config/stress_config.h"
#include "harness/embree/embree_bvh_builder.h"
#include "harness/report/report.h"
#include "harness/report/stress_report.h"
#include "harness/run/bounded_run.h"
#include "harness/run/csv.h"
#include "harness/run/stress_metrics.h"
#include "harness/run/stress_runner.h"
#include "scenes/stress_cases.h"
#include "tests/support/error_of.h"
#include "tests/support/process_temp_dir.h"
#include "traversal/exact_reference.h"
#include "traversal/layout.h"

namespace sahbench {
namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();

ExactHit exact_hit(std::vector<uint32_t> tied, float t) {
  ExactHit e;
  e.tied = std::move(tied);
  e.t = t;
  return e;
}

TEST(HarnessStressMetrics, CountsEachKindOfErrorAgainstTheExactAnswers) {
  const std::vector<ExactHit> exact = {
      exact_hit({3}, 1.0f),     // 0: the variant misses it (a must-hit ray: a leak too)
      exact_hit({}, kInf),      // 1: the variant hits something that is not there
      exact_hit({4}, 2.0f),     // 2: the variant hits prim 5 at the same t: wrong primitive, near
      exact_hit({6, 7}, 3.0f),  // 3: a tie; the variant's prim 7 is accepted, 2 ulps off
      exact_hit({8}, 4.0f),     // 4: the variant hits prim 9 far behind: wrong primitive, far
      exact_hit({1}, 5.0f),     // 5: exact, to the ulp
      exact_hit({2}, 1.0f),     // 6: an infinite t on the right primitive: max saturates, mean skips it
  };
  const std::vector<Hit> hits = {Hit{},
                                 Hit{0, 1.0f, 0, 0},
                                 Hit{5, 2.0f, 0, 0},
                                 Hit{7, std::nextafter(std::nextafter(3.0f, 4.0f), 4.0f), 0, 0},
                                 Hit{9, 8.0f, 0, 0},
                                 Hit{1, 5.0f, 0, 0},
                                 Hit{2, kInf, 0, 0}};
  const std::vector<uint8_t> must_hit = {1, 0, 0, 0, 0, 0, 0};
  const ErrorMetrics m = measure_errors(hits, exact, must_hit);
  EXPECT_EQ(m.rays, 7u);
  EXPECT_EQ(m.exact_hits, 6u);
  EXPECT_EQ(m.false_misses, 1u);
  EXPECT_EQ(m.leaks, 1u);
  EXPECT_EQ(m.false_hits, 1u);
  EXPECT_EQ(m.wrong_prim, 2u);
  EXPECT_EQ(m.wrong_prim_far, 1u);
  EXPECT_EQ(m.ties, 1u);
  EXPECT_EQ(m.t_err_ulps_max, std::numeric_limits<uint32_t>::max());
  EXPECT_DOUBLE_EQ(m.t_err_ulps_mean, 1.0);  // (2 + 0) / 2
  EXPECT_THROW(measure_errors(std::span(hits).first(2), exact, {}), Error);
  EXPECT_EQ(m.t_err_ulps_max_clear, 0u);  // no rays given
}

// The t error clear of the origin leaves out hits within 2^-20 |org| of it (a ray starting on a surface),
// however many ulps off, and keeps the others.
TEST(HarnessStressMetrics, TErrorClearOfTheOriginLeavesOutHitsAtTheOrigin) {
  const Ray from_surface{{1, 0, 0}, 0.0f, {1, 0, 0}, kInf};
  EXPECT_FALSE(is_clear_of_origin(from_surface, 0.0f));
  EXPECT_FALSE(is_clear_of_origin(from_surface, 0x1p-21f));
  EXPECT_TRUE(is_clear_of_origin(from_surface, 0x1p-20f));
  EXPECT_TRUE(is_clear_of_origin(Ray{{0, 0, 0}, 0.0f, {0, 0, 1}, kInf}, 1e-30f));
  const std::vector<ExactHit> exact = {exact_hit({1}, 1e-7f), exact_hit({2}, 2.0f)};
  const std::vector<Hit> hits = {Hit{1, 3e-7f, 0, 0}, Hit{2, std::nextafter(2.0f, 3.0f), 0, 0}};
  const std::vector<Ray> rays = {from_surface, from_surface};
  const ErrorMetrics m = measure_errors(hits, exact, {}, rays);
  EXPECT_GT(m.t_err_ulps_max, 1000u);
  EXPECT_EQ(m.t_err_ulps_max_clear, 1u);
  EXPECT_THROW(measure_errors(hits, exact, {}, std::span(rays).first(1)), Error);
}

TEST(HarnessBoundedRun, ReturnsResultsAndErrorsAndAbandonsWorkPastTheBound) {
  const auto done = run_bounded<int>([] { return 42; }, 10.0);
  ASSERT_TRUE(done.value);
  EXPECT_EQ(*done.value, 42);
  const auto threw = run_bounded<int>([]() -> int { throw Error("bad input"); }, 10.0);
  EXPECT_FALSE(threw.value);
  EXPECT_FALSE(threw.timed_out);
  EXPECT_EQ(threw.error, "bad input");
  // Work that waits for a flag only the test sets after the bound: abandoned, then released.
  auto release = std::make_shared<std::atomic<bool>>(false);
  const auto slow = run_bounded<int>(
      [release] {
        while (!release->load()) std::this_thread::sleep_for(std::chrono::milliseconds(1));
        return 1;
      },
      0.05);
  EXPECT_TRUE(slow.timed_out);
  EXPECT_FALSE(slow.value);
  release->store(true);
}

TEST(HarnessStressCases, AreDeterministicAndKeepTheirPromises) {
  for (const StressKindInfo& kind : stress_kinds()) {
    StressCaseSpec spec;
    spec.name = std::string(kind.name);
    spec.kind = std::string(kind.name);
    spec.size = 200;
    spec.rays = 300;
    const StressCase a = generate_stress_case(spec), b = generate_stress_case(spec);
    SCOPED_TRACE(spec.kind);
    EXPECT_EQ(a.scene.triangles, b.scene.triangles);
    ASSERT_EQ(a.rays.size(), b.rays.size());
    for (std::size_t i = 0; i < a.rays.size(); ++i) {
      EXPECT_EQ(std::memcmp(&a.rays[i], &b.rays[i], sizeof(Ray)), 0) << "ray " << i;  // bitwise, -0 included
    }
    EXPECT_FALSE(a.scene.triangles.empty());
    EXPECT_GT(a.rays.size(), 0u);
    EXPECT_EQ(a.must_hit.size(), a.rays.size());
    EXPECT_EQ(a.scene.removed.total(), a.invalid_made);
    EXPECT_EQ(a.closed, kind.closed);
    // Every ray flagged must-hit hits exactly; on closed kinds every ray is flagged but axis_rays'.
    const std::vector<ExactHit> exact = ExactReference(a.scene.triangles).closest(a.rays);
    std::size_t flagged = 0;
    for (std::size_t i = 0; i < a.rays.size(); ++i) {
      flagged += a.must_hit[i];
      if (a.must_hit[i]) {
        EXPECT_TRUE(exact[i].found()) << "ray " << i;
      }
    }
    if (kind.closed && kind.name != "axis_rays") {
      EXPECT_EQ(flagged, a.rays.size());
    }
  }
  // The degenerate kind makes zero-area and non-finite triangles, and the filter counts both.
  StressCaseSpec degenerate{"d", "degenerate", 1, 240, 10};
  const StressCase d = generate_stress_case(degenerate);
  EXPECT_EQ(d.invalid_made, 60u);
  EXPECT_EQ(d.scene.removed.zero_area, 30u);
  EXPECT_EQ(d.scene.removed.non_finite, 30u);
  EXPECT_THROW(generate_stress_case({"x", "no_such_kind"}), Error);
}

TEST(HarnessStressConfig, ChecksKindsParametersAndNames) {
  const std::string head =
      "[stress]\nname = \"s\"\nbuilders = [\"binned_sah\"]\nlayouts = [\"bvh2\", \"bvh2:tri=mt\"]\n";
  const StressConfig c = parse_stress_config(
      head + "[[case]]\nname = \"a\"\nkind = \"sphere\"\nscale = 1e-6\nrays = 10\n", "t.toml");
  ASSERT_EQ(c.cases.size(), 1u);
  EXPECT_EQ(c.cases[0].scale, 1e-6);
  EXPECT_EQ(c.cases[0].rays, 10u);
  EXPECT_EQ(c.layouts,
            (std::vector<LayoutSpec>{parse_layout_spec("bvh2"), parse_layout_spec("bvh2:tri=mt")}));
  EXPECT_EQ(c.output, "results/s.csv");
  auto error_of = [&](const std::string& text) {
    try {
      parse_stress_config(text, "t.toml");
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_NE(error_of(head + "[[case]]\nname = \"a\"\nkind = \"cube\"\n")
                .find("t.toml:7: unknown stress case kind 'cube'"),
            std::string::npos);
  EXPECT_NE(error_of(head + "[[case]]\nname = \"a\"\nkind = \"grazing\"\nscale = 2\n")
                .find("does not read 'scale'"),
            std::string::npos);
  EXPECT_NE(
      error_of(head +
               "[[case]]\nname = \"a\"\nkind = \"grazing\"\n[[case]]\nname = \"a\"\nkind = \"sphere\"\n")
          .find("used twice"),
      std::string::npos);
  EXPECT_NE(
      error_of("[stress]\nname = \"s\"\nbuilders = [\"nope\"]\n[[case]]\nname = \"a\"\nkind = \"sphere\"\n")
          .find("t.toml:3: stress.builders: unknown builder 'nope'"),
      std::string::npos);
  EXPECT_NE(
      error_of(head + "[[case]]\nname = \"a\"\nkind = \"sphere\"\nsize = 0\n").find("size = 0 is outside"),
      std::string::npos);
  EXPECT_NE(error_of(head).find("no [[case]] tables"), std::string::npos);
}

TEST(HarnessStressConfig, DefaultsCoverEveryBuilderLayoutAndVariant) {
  register_embree_builders();
  const std::vector<BuilderRun> specs = all_builder_specs();
  for (const BuilderInfo& b : builders())
    EXPECT_NE(std::find(specs.begin(), specs.end(), BuilderRun{b.name, {}}), specs.end()) << b.name;
  std::vector<std::string> variants;
  for (const LayoutSpec& spec : all_layout_variants()) variants.push_back(spec.text());
  EXPECT_EQ(variants.size(), layouts().size() * 12);  // 4 triangle tests x 3 box tests
  for (const LayoutInfo& l : layouts()) {
    EXPECT_NE(std::find(variants.begin(), variants.end(), l.name), variants.end()) << l.name;
    EXPECT_NE(std::find(variants.begin(), variants.end(), l.name + ":tri=mt0,box=fast"), variants.end())
        << l.name;
    EXPECT_NE(std::find(variants.begin(), variants.end(), l.name + ":tri=mt0,box=fma"), variants.end())
        << l.name;
    EXPECT_NE(std::find(variants.begin(), variants.end(), l.name + ":tri=mtn,box=fma"), variants.end())
        << l.name;
  }
}

// A stress config named `name` that traces once, without warm-up, and gives a build a minute.
StressConfig quick_stress_config(const std::string& name) {
  StressConfig cfg;
  cfg.path = name;
  cfg.name = name;
  cfg.trace_reps = 1;
  cfg.trace_warmup = 0;
  cfg.build_time_limit_s = 60;
  return cfg;
}

// A layout the CPU cannot run (16-ray packets without AVX-512) is skipped with its reason, as in `run`.
TEST(HarnessStress, SkipsLayoutsTheCpuCannotRun) {
  StressConfig cfg = quick_stress_config("skip");
  for (const auto& b : all_builder_specs())
    if (b.name == "wide_collapse") cfg.builders.push_back(b);
  ASSERT_FALSE(cfg.builders.empty());
  cfg.layouts = {parse_layout_spec("bvh8"), parse_layout_spec("bvh8:packet=16")};
  cfg.cases.push_back(StressCaseSpec{"sphere", "sphere", 1, 80, 120});
  const auto csv = test::process_temp_dir("stress") / "skip.csv";
  std::filesystem::remove(csv);
  std::ostringstream log;
  const StressSummary summary = run_stress(cfg, {"", csv, ""}, log);
  EXPECT_TRUE(summary.failures.empty()) << log.str();
  std::set<std::string> traced;
  for (const CsvRow& r : read_csv(csv))
    if (r.at("builder") != "embree" && !r.at("layout").empty()) traced.insert(r.at("layout"));
  const bool skipped =
      log.str().find("skipping layout bvh8:packet=16: 16-ray packets need AVX-512") != std::string::npos;
  EXPECT_EQ(skipped, !kernel_isa_available(KernelIsa::kAvx512)) << log.str();
  const std::set<std::string> expected =
      skipped ? std::set<std::string>{"bvh8"} : std::set<std::string>{"bvh8", "bvh8:packet=16"};
  EXPECT_EQ(traced, expected);
  // A case filter that matches nothing is refused, naming the cases, before the output is touched.
  std::filesystem::remove(csv);
  const std::string e = test::error_of([&] { run_stress(cfg, {"", csv, "no_such_case"}, log); });
  EXPECT_NE(e.find("--only 'no_such_case' matches no case of"), std::string::npos) << e;
  EXPECT_NE(e.find("(its cases: sphere)"), std::string::npos) << e;
  EXPECT_FALSE(std::filesystem::exists(csv));
}

// The reduced suite: every kind at a small size, every builder, every layout variant, both Embree modes.
TEST(HarnessStress, ReducedSuiteKeepsItsGuarantees) {
  register_embree_builders();
  StressConfig cfg = quick_stress_config("reduced");
  cfg.builders = all_builder_specs();
  cfg.layouts = all_layout_variants();
  auto add = [&](std::string name, std::string kind, uint64_t size, uint32_t rays, double scale = 1,
                 double offset = 0) {
    StressCaseSpec s{std::move(name), std::move(kind), 1, size, rays};
    s.scale = scale;
    s.offset = offset;
    cfg.cases.push_back(s);
  };
  add("sphere_far", "sphere", 80, 240, 1e3, 1e6);
  add("cube_micro", "cube_grid", 108, 240, 1e-6);
  add("axis_rays", "axis_rays", 96, 240);
  add("tiny_in_huge", "tiny_in_huge", 172, 120);
  add("grazing", "grazing", 8, 120);
  add("huge_tiny", "huge_tiny", 40, 100);
  add("degenerate", "degenerate", 200, 100);
  add("same_centroid", "same_centroid", 200, 60);
  add("coincident", "coincident", 3000, 16);
  add("needles", "needles", 200, 100);
  add("surface_origin", "surface_origin", 80, 120);
  add("empty_interval", "empty_interval", 48, 120);
  const auto csv = test::process_temp_dir("stress") / "stress.csv";
  std::filesystem::remove(csv);
  std::ostringstream log;
  const StressSummary summary = run_stress(cfg, {"", csv, ""}, log);
  EXPECT_TRUE(summary.failures.empty()) << log.str();
  EXPECT_EQ(summary.abandoned_builds, 0u);

  const std::vector<CsvRow> rows = read_csv(csv);
  EXPECT_EQ(rows.size(), summary.rows);
  std::set<std::pair<std::string, std::string>> built;  // (case, builder params) of every build
  for (const CsvRow& r : rows) {
    SCOPED_TRACE(r.at("scene") + " " + r.at("builder") + " " + r.at("builder_params") + " " + r.at("layout"));
    EXPECT_EQ(r.at("build_failed"), "0") << r.at("notes");
    if (r.at("builder") != "embree") {
      EXPECT_EQ(r.at("nan_bounds"), "0");
      built.insert({r.at("scene"), r.at("builder") + r.at("builder_params")});
    }
    EXPECT_FALSE(r.at("trace_mrays_median").empty()) << r.at("notes");
    const bool default_kernels = r.at("layout").find(':') == std::string::npos && r.at("builder") != "embree";
    if (r.at("closed") == "1" && default_kernels) {
      EXPECT_EQ(r.at("false_misses"), "0");
      EXPECT_EQ(r.at("leaks"), "0");
    }
    // Rays through shared vertices and edges of the closed meshes are exact ties.
    if (r.at("case_kind") == "sphere" || r.at("case_kind") == "cube_grid") {
      EXPECT_NE(r.at("ties"), "0");
    }
  }
  // Every builder ran on every case, and every layout variant was traced on each case.
  EXPECT_EQ(built.size(), cfg.cases.size() * cfg.builders.size());
  for (const LayoutSpec& spec : cfg.layouts) {
    const std::string variant = spec.text();
    std::size_t traced = 0;
    for (const CsvRow& r : rows) traced += r.at("layout") == variant;
    EXPECT_GE(traced, cfg.cases.size()) << variant;
  }
  // Errors the suite must see, so that its zeros mean something: Embree's interval is open at tmin, so
  // in its default mode it misses the exact hits of rays with tmin = tmax.
  std::size_t embree_default_rows = 0;
  for (const CsvRow& r : rows)
    if (r.at("scene") == "empty_interval" && r.at("builder_params") == "quality=medium;mode=default") {
      ++embree_default_rows;
      EXPECT_NE(r.at("false_misses"), "0");
    }
  EXPECT_GT(embree_default_rows, 0u) << "no row of Embree's default mode on empty_interval";

  std::ostringstream report;
  print_report({{csv}, ""}, report);
  EXPECT_NE(report.str().find("## Error against run time, all cases"), std::string::npos) << report.str();
  EXPECT_NE(report.str().find("| embree (robust) | embree_1 |"), std::string::npos) << report.str();
  EXPECT_NE(report.str().find("## Where a variant is wrong"), std::string::npos);
  std::ostringstream latex;
  print_report({{csv}, "", ReportFormat::kLatex}, latex);
  EXPECT_NE(latex.str().find("\\label{tab:stress}"), std::string::npos) << latex.str();
  EXPECT_NE(latex.str().find("embree (robust) & embree\\_1"), std::string::npos) << latex.str();
}

// A variant whose build failed on a slow case would gain that case's weight: speeds are compared over
// the cases every traced variant traced, and the counts of cases are not marked as a best. A builder run
// with two parameter sets is two variants.
TEST(HarnessStressReport, ComparesSpeedsOverTheCasesEveryVariantTraced) {
  auto row = [](const std::string& scene, const std::string& builder, const std::string& params,
                const std::string& mrays) {
    CsvRow r = {{"run_id", "x"},
                {"git_commit", "x"},
                {"cpu", "x"},
                {"compiler", "x"},
                {"embree_version", "x"},
                {"config", "x"},
                {"notes", ""},
                {"false_misses", "0"},
                {"leaks", "0"},
                {"false_hits", "0"},
                {"wrong_prim", "0"},
                {"wrong_prim_far", "0"},
                {"t_err_ulps_max", "0"},
                {"t_err_ulps_mean", "0"},
                {"exact_hits", "0"},
                {"nan_bounds", "0"},
                {"threads", "1"},
                {"trace_reps", "1"},
                {"build_time_limit_s", "1"},
                {"case_kind", "x"},
                {"scene_triangles", "1"},
                {"scene_removed", "0"},
                {"ray_count", "1"},
                {"ties", "0"},
                {"must_hit_rays", "0"},
                {"closed", "0"},
                {"reference_ms", "1"}};
    r["scene"] = scene;
    r["builder"] = builder;
    r["builder_params"] = params;
    // As the stress runner writes them: a build that failed is a row without a layout.
    r["layout"] = mrays.empty() ? "" : "bvh8";
    r["trace_mrays_median"] = mrays;
    r["build_failed"] = mrays.empty() ? "1" : "0";
    return r;
  };
  // On the two cases both traced, b is as fast as a; b's build failed on the slow third case. c runs with
  // two parameter sets, the second twice as fast.
  const std::vector<CsvRow> rows = {
      row("fast", "a", "", "100"),        row("slow", "a", "", "1"),        row("mid", "a", "", "10"),
      row("fast", "b", "", "100"),        row("slow", "b", "", ""),         row("mid", "b", "", "10"),
      row("fast", "c", "bins=8", "100"),  row("slow", "c", "bins=8", "1"),  row("mid", "c", "bins=8", "10"),
      row("fast", "c", "bins=32", "200"), row("slow", "c", "bins=32", "2"), row("mid", "c", "bins=32", "20")};
  std::ostringstream out;
  print_stress_report(rows, ReportFormat::kMarkdown, out);
  const std::string text = out.str();
  // Cases, traced, Mrays/s (ratio to a's): 31.62 is the geometric mean of 100 and 10, for a and for b,
  // where over a's three cases a would read 10.00 and b 3.16 times it.
  EXPECT_NE(text.find("| a | bvh8 | 3 | 3 | 31.62 (1.00x) |"), std::string::npos) << text;
  EXPECT_NE(text.find("| b | bvh8 | 2 | 2 | 31.62 (1.00x) |"), std::string::npos) << text;
  EXPECT_NE(text.find("| b | (not traced) | 1 | 0 | - |"), std::string::npos) << text;
  EXPECT_NE(text.find("| c [bins=8] | bvh8 | 3 | 3 | 31.62 (1.00x) |"), std::string::npos) << text;
  EXPECT_NE(text.find("| c [bins=32] | bvh8 | 3 | 3 | **63.25** (2.00x) |"), std::string::npos) << text;
  EXPECT_NE(text.find("over the 2 cases that every traced variant traced"), std::string::npos) << text;
  EXPECT_EQ(text.find("| **3** |"), std::string::npos) << text;
}

}  // namespace
}  // namespace sahbench
