#pragma once
// Result CSVs as `compare` and `report` read them: each row with the line it starts on, so that an error
// can name file, line and column; the anchor of every ratio to Embree; and the checked reading of a
// row's numbers and timing samples, done once here for both commands.

#include <cstddef>
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "core/error.h"
#include "harness/run/csv.h"

namespace sahbench {

/// The anchor of every ratio to Embree: Embree's own BVH at medium quality, traced one ray at a time
/// (rtcIntersect1 / rtcOccluded1), in the same run, scene, threads, ray set and frame as the row.
inline constexpr std::string_view kAnchorBuilder = "embree";
inline constexpr std::string_view kAnchorParams = "quality=medium";
inline constexpr std::string_view kAnchorLayout = "embree_1";

/// Whether a row of this builder, builder_params and layout is the anchor.
bool is_anchor(std::string_view builder, std::string_view params, std::string_view layout);
/// The same for a CSV row; absent fields count as empty.
bool is_anchor(const CsvRow& row);

/// The like-for-like anchor of our exact kernels, where a run has it: Embree's robust mode
/// (RTC_SCENE_FLAG_ROBUST, which also selects its watertight triangle test) at medium quality, one ray
/// at a time, in the same run, scene, threads, ray set and frame as the row.
inline constexpr std::string_view kRobustAnchorParams = "quality=medium;robust=1";

/// Whether a CSV row is the robust anchor (builder embree, kRobustAnchorParams, kAnchorLayout).
bool is_robust_anchor(const CsvRow& row);

/// Whether a row of ours runs exact kernels, to be compared with Embree's robust mode rather than its
/// default: its layout's triangle test is watertight and its box test robust (the defaults,
/// traversal/kernel_variant.h), whatever its any-hit order or ISA. False for Embree's rows, for any
/// faster variant (tri=mt, mt0, mtn or box=fast, fma), and for a layout this build does not know (an
/// older CSV's), which keep Embree's default mode as their anchor.
bool runs_exact_kernels(std::string_view builder, std::string_view layout);

/// Whether a CSV row is Embree medium traced in packets (a layout embree_8 or embree_16), in its robust
/// mode (`robust`) or its default one: the anchors of our packet layouts, which are compared with the
/// fastest of Embree's packet widths in the same cell.
bool is_packet_anchor(const CsvRow& row, bool robust);

/// Whether a row of ours traces packets (a layout with packet=8 or packet=16).
bool runs_packets(std::string_view builder, std::string_view layout);

/// One result CSV: read_csv's rows, and the line each starts on (the header is line 1; a quoted field
/// may span lines, and blank lines are skipped, so the line is not the row's index + 2).
struct ResultFile {
  std::filesystem::path path;
  std::vector<CsvRow> rows;
  std::vector<std::size_t> lines;  ///< lines[i]: the line rows[i] starts on
  /// Its last line has no newline: a row cut off mid-write (a run killed while writing), which read_csv
  /// leaves out; readers say so rather than lose the cell silently.
  bool cut_last_line = false;

  /// "PATH:LINE" of row i.
  std::string where(std::size_t i) const;
  /// Whether the header has `column` (a file without rows has none).
  bool has_column(const std::string& column) const;
  /// The field of row i; empty when the header lacks the column.
  const std::string& field(std::size_t i, const std::string& column) const;
};

/// Reads `path` with read_csv (its errors unchanged) and finds the line of each row.
ResultFile read_result_file(const std::filesystem::path& path);

/// An Error "PATH:LINE: column 'COLUMN': WHAT" for row i.
Error row_error(const ResultFile& file, std::size_t i, const std::string& column, const std::string& what);

/// A numeric field of row i: nullopt when empty or absent; the whole field must be a finite number,
/// otherwise an Error naming file, line, column and value (csv_number would read "12abc" as 12).
std::optional<double> checked_number(const ResultFile& file, std::size_t i, const std::string& column);

/// An integer field of row i (threads, frame); empty, absent or not an integer is an Error naming it.
int checked_integer(const ResultFile& file, std::size_t i, const std::string& column);

/// The samples of row i for `prefix` ("build_ms" or "trace_mrays"), parsed from PREFIX_samples (see
/// parse_samples); none when that field is empty or absent. A bad value, or samples whose median is not
/// PREFIX_median as printed (4 decimals), is an Error naming file, line and column.
std::vector<double> timing_samples(const ResultFile& file, std::size_t i, const std::string& prefix);

}  // namespace sahbench
