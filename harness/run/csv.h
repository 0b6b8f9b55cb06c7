#pragma once
// CSV results: one row per finished cell, appended and flushed at once so that a crash or Ctrl-C loses
// no finished row. Quoting follows RFC 4180 (fields with a comma, quote or newline are quoted).

#include <filesystem>
#include <fstream>
#include <map>
#include <optional>
#include <string>
#include <vector>

namespace sahbench {

/// The DESIGN.md columns, in order (those of the cell pipeline last: run_fingerprint, build_ms_samples,
/// trace_mrays_samples, build_layout_ms_median, hit_fraction); more may follow, these are never renamed.
const std::vector<std::string>& design_columns();

using CsvRow = std::map<std::string, std::string>;

/// Appends rows with a fixed header. Opening an existing file checks its header matches (an error
/// naming the file and the first differing column otherwise); a new or empty file gets the header.
/// Every row is written with its newline, so a last line without one is a row cut off by a crash: the
/// writer removes it (dropped_partial_row() says so) and the row's cell is simply not finished.
class CsvWriter {
 public:
  CsvWriter(std::filesystem::path path, std::vector<std::string> columns);
  bool dropped_partial_row() const { return dropped_partial_row_; }
  /// Writes one row; columns missing from `row` are empty, keys not in the header are an error.
  void append(const CsvRow& row);
  const std::filesystem::path& path() const { return path_; }

 private:
  std::filesystem::path path_;
  std::vector<std::string> columns_;
  std::ofstream out_;
  bool dropped_partial_row_ = false;
};

/// Reads a whole CSV file into rows keyed by header names; lines starting with '#' before the header are
/// comments and skipped. Malformed quoting or a row with the wrong
/// number of fields is an error naming the file and line. A last line without its newline is a row
/// being written (or cut off) and is left out.
std::vector<CsvRow> read_csv(const std::filesystem::path& path);

/// A numeric field of `row`; empty, absent or not a number gives nullopt.
std::optional<double> csv_number(const CsvRow& row, const std::string& column);

/// One field, quoted when needed.
std::string csv_escape(const std::string& field);

}  // namespace sahbench
