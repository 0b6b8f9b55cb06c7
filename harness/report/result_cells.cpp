#include "harness/report/result_cells.h"

#include <fmt/format.h>

#include <charconv>
#include <cmath>
#include <fstream>
#include <iterator>

#include "core/error.h"
#include "core/text_file.h"
#include "harness/report/ratio_stats.h"
#include "traversal/layout.h"

namespace sahbench {
namespace {

// The line each record of `text` starts on, found as read_csv splits records (csv.cpp): a newline
// inside quotes belongs to the field, a doubled quote inside quotes is one quote, a record of one empty
// field is a blank line and skipped, and a last line without its newline is left out. The first record
// is the header.
std::vector<std::size_t> record_lines(std::string text) {
  text.resize(text.rfind('\n') == std::string::npos ? 0 : text.rfind('\n') + 1);
  std::vector<std::size_t> lines;
  std::size_t pos = 0, line = 1;
  // Comment lines before the header are not records, as read_csv skips them.
  while (pos < text.size() && text[pos] == '#') {
    pos = text.find('\n', pos) + 1;
    ++line;
  }
  while (pos < text.size()) {
    const std::size_t start_line = line;
    bool quoted = false, several_fields = false, field_text = false;
    while (pos < text.size()) {
      const char c = text[pos++];
      if (quoted) {
        if (c == '"' && pos < text.size() && text[pos] == '"') {
          ++pos;
          field_text = true;
        } else if (c == '"') {
          quoted = false;
        } else {
          line += c == '\n';
          field_text = true;
        }
      } else if (c == '"') {
        quoted = true;
      } else if (c == ',') {
        several_fields = true;
      } else if (c == '\n') {
        ++line;
        break;
      } else if (c != '\r') {
        field_text = true;
      }
    }
    if (several_fields || field_text || lines.empty()) lines.push_back(start_line);
  }
  if (!lines.empty()) lines.erase(lines.begin());  // the header
  return lines;
}

// A whole field as a number: from_chars must take all of it.
std::optional<double> parse_number(const std::string& text) {
  double value = 0.0;
  const auto [ptr, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
  if (ec != std::errc() || ptr != text.data() + text.size()) return std::nullopt;
  return value;
}

// Samples and the median column are both printed with 4 decimals (result_row.cpp), so their medians
// agree to within one unit of the last place (two roundings of half a unit each).
constexpr double kMedianTolerance = 1e-4;

}  // namespace

bool is_anchor(std::string_view builder, std::string_view params, std::string_view layout) {
  return builder == kAnchorBuilder && params == kAnchorParams && layout == kAnchorLayout;
}

namespace {

std::string_view get(const CsvRow& row, const char* column) {
  const auto it = row.find(column);
  return it == row.end() ? std::string_view() : std::string_view(it->second);
}

}  // namespace

bool is_anchor(const CsvRow& row) {
  return is_anchor(get(row, "builder"), get(row, "builder_params"), get(row, "layout"));
}

bool is_robust_anchor(const CsvRow& row) {
  return get(row, "builder") == kAnchorBuilder && get(row, "builder_params") == kRobustAnchorParams &&
         get(row, "layout") == kAnchorLayout;
}

bool is_packet_anchor(const CsvRow& row, bool robust) {
  const std::string_view layout = get(row, "layout");
  return get(row, "builder") == kAnchorBuilder &&
         get(row, "builder_params") == (robust ? kRobustAnchorParams : kAnchorParams) &&
         (layout == "embree_8" || layout == "embree_16");
}

namespace {

// Our layout spec of a row, if it is one this build knows.
std::optional<LayoutSpec> our_layout(std::string_view builder, std::string_view layout) {
  if (builder == kAnchorBuilder || layout.empty()) return std::nullopt;
  try {
    return parse_layout_spec(layout);
  } catch (const Error&) {
    return std::nullopt;
  }
}

}  // namespace

bool runs_exact_kernels(std::string_view builder, std::string_view layout) {
  const auto spec = our_layout(builder, layout);
  const KernelVariant exact;
  return spec && spec->variant.triangle == exact.triangle && spec->variant.box == exact.box;
}

bool runs_packets(std::string_view builder, std::string_view layout) {
  const auto spec = our_layout(builder, layout);
  return spec && spec->packet > 1;
}

std::string ResultFile::where(std::size_t i) const {
  return path.string() + ":" + std::to_string(lines.at(i));
}

bool ResultFile::has_column(const std::string& column) const {
  return !rows.empty() && rows.front().count(column) > 0;
}

const std::string& ResultFile::field(std::size_t i, const std::string& column) const {
  static const std::string empty;
  const auto it = rows.at(i).find(column);
  return it == rows[i].end() ? empty : it->second;
}

ResultFile read_result_file(const std::filesystem::path& path) {
  ResultFile file{path, read_csv(path), {}};
  const std::string text = read_text_file(path, "result CSV");
  file.lines = record_lines(text);
  file.cut_last_line = !text.empty() && text.back() != '\n';
  // Both read the same text by the same rules; a difference is a bug here, not bad input.
  if (file.lines.size() != file.rows.size())
    throw std::logic_error(fmt::format("{}: {} rows read, but {} found by line", path.string(),
                                       file.rows.size(), file.lines.size()));
  return file;
}

Error row_error(const ResultFile& file, std::size_t i, const std::string& column, const std::string& what) {
  return Error(file.where(i) + ": column '" + column + "': " + what);
}

std::optional<double> checked_number(const ResultFile& file, std::size_t i, const std::string& column) {
  const std::string& text = file.field(i, column);
  if (text.empty()) return std::nullopt;
  const auto value = parse_number(text);
  if (!value) throw row_error(file, i, column, "'" + text + "' is not a number");
  if (!std::isfinite(*value)) throw row_error(file, i, column, "'" + text + "' is not finite");
  return value;
}

int checked_integer(const ResultFile& file, std::size_t i, const std::string& column) {
  const std::string& text = file.field(i, column);
  int value = 0;
  const auto [ptr, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
  if (text.empty() || ec != std::errc() || ptr != text.data() + text.size())
    throw row_error(file, i, column, "'" + text + "' is not an integer");
  return value;
}

std::vector<double> timing_samples(const ResultFile& file, std::size_t i, const std::string& prefix) {
  const std::string column = prefix + "_samples", median_column = prefix + "_median";
  std::vector<double> samples;
  try {
    samples = parse_samples(file.field(i, column));
  } catch (const Error& e) {
    throw row_error(file, i, column, e.what());
  }
  if (samples.empty()) return samples;
  const auto median = checked_number(file, i, median_column);
  const double of_samples = median_of(samples);
  if (!median || std::fabs(of_samples - *median) > kMedianTolerance + 1e-9 * (1.0 + std::fabs(*median)))
    throw row_error(file, i, column,
                    fmt::format("the samples' median {:.4f} is not {} '{}'", of_samples, median_column,
                                file.field(i, median_column)));
  return samples;
}

}  // namespace sahbench
