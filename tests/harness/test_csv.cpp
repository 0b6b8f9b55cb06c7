#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "core/error.h"
#include "harness/run/csv.h"
#include "harness/run/result_row.h"
#include "tests/support/process_temp_dir.h"

namespace sahbench {
namespace {

std::filesystem::path temp_file(const std::string& name) {
  const auto dir = test::process_temp_dir("csv");
  const auto path = dir / name;
  std::filesystem::remove(path);
  return path;
}

TEST(HarnessCsv, RoundTripWithQuotingAndAppendAcrossWriters) {
  const auto path = temp_file("round_trip.csv");
  {
    CsvWriter w(path, {"a", "b", "c"});
    w.append({{"a", "1"}, {"b", "x,y"}, {"c", "say \"hi\""}});
  }
  {
    CsvWriter w(path, {"a", "b", "c"});  // reopening appends under the same header
    w.append({{"a", "2"}, {"c", "line\nbreak"}});
  }
  const auto rows = read_csv(path);
  ASSERT_EQ(rows.size(), 2u);
  EXPECT_EQ(rows[0].at("b"), "x,y");
  EXPECT_EQ(rows[0].at("c"), "say \"hi\"");
  EXPECT_EQ(rows[1].at("b"), "");
  EXPECT_EQ(rows[1].at("c"), "line\nbreak");
}

TEST(HarnessCsv, RowsAreOnDiskAsSoonAsAppended) {
  const auto path = temp_file("flushed.csv");
  CsvWriter w(path, {"a"});
  w.append({{"a", "1"}});
  EXPECT_EQ(read_csv(path).size(), 1u);  // while the writer is still open
}

TEST(HarnessCsv, DifferentHeaderIsAnErrorNamingTheColumn) {
  const auto path = temp_file("header.csv");
  { CsvWriter w(path, {"a", "b"}); }
  try {
    CsvWriter w(path, {"a", "c"});
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("column 2"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("'b'"), std::string::npos) << e.what();
  }
}

TEST(HarnessCsv, UnknownColumnInARowIsAnError) {
  const auto path = temp_file("unknown.csv");
  CsvWriter w(path, {"a"});
  EXPECT_THROW(w.append({{"z", "1"}}), Error);
}

TEST(HarnessCsv, MalformedFilesAreErrorsWithTheLine) {
  const auto path = temp_file("bad.csv");
  std::ofstream(path) << "a,b\n1,2\n3\n";
  try {
    read_csv(path);
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find(":3:"), std::string::npos) << e.what();
  }
  std::ofstream(path) << "a\n\"open\n";
  EXPECT_THROW(read_csv(path), Error);
}

TEST(HarnessCsv, DesignColumnsComeFirstAndInOrder) {
  const auto& c = design_columns();
  // DESIGN.md's 37, then the cell pipeline's five.
  ASSERT_EQ(c.size(), 42u);
  EXPECT_EQ(c.front(), "run_id");
  EXPECT_EQ(c[36], "mismatches");
  EXPECT_EQ(std::vector<std::string>(c.begin() + 37, c.end()),
            (std::vector<std::string>{"run_fingerprint", "build_ms_samples", "trace_mrays_samples",
                                      "build_layout_ms_median", "hit_fraction"}));
}

TEST(HarnessCsv, CellSummaryNamesMismatchesOrTheirAbsence) {
  CsvRow row{{"build_ms_median", "1.5"}, {"trace_mrays_median", "2.25"}, {"mismatches", "0"}};
  EXPECT_EQ(cell_summary("bunny bvh8", row), "bunny bvh8: build 1.5 ms, 2.25 Mrays/s, 0 mismatches");
  row["mismatches"] = "";
  EXPECT_EQ(cell_summary("bunny bvh8", row), "bunny bvh8: build 1.5 ms, 2.25 Mrays/s, no reference");
}

}  // namespace
}  // namespace sahbench
