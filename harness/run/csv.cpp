#include "harness/run/csv.h"

#include <algorithm>
#include <iterator>

#include "core/error.h"
#include "core/text_file.h"

namespace sahbench {
namespace {

// Splits one record starting at `pos`; handles quoted fields spanning lines. Returns false at EOF.
bool next_record(const std::string& text, std::size_t& pos, std::vector<std::string>& fields,
                 std::size_t& line, const std::filesystem::path& path) {
  fields.clear();
  if (pos >= text.size()) return false;
  std::string field;
  bool quoted = false;
  const std::size_t start_line = line;
  while (pos < text.size()) {
    const char c = text[pos++];
    if (quoted) {
      if (c == '"') {
        if (pos < text.size() && text[pos] == '"') {
          field += '"';
          ++pos;
        } else {
          quoted = false;
        }
      } else {
        if (c == '\n') ++line;
        field += c;
      }
    } else if (c == '"') {
      if (!field.empty())
        throw Error(path.string() + ":" + std::to_string(line) + ": a quote inside an unquoted field");
      quoted = true;
    } else if (c == ',') {
      fields.push_back(std::move(field));
      field.clear();
    } else if (c == '\n') {
      ++line;
      break;
    } else if (c != '\r') {
      field += c;
    }
  }
  if (quoted) throw Error(path.string() + ":" + std::to_string(start_line) + ": unterminated quoted field");
  fields.push_back(std::move(field));
  return true;
}

}  // namespace

const std::vector<std::string>& design_columns() {
  static const std::vector<std::string> columns = {"run_id",
                                                   "git_commit",
                                                   "cpu",
                                                   "isa",
                                                   "compiler",
                                                   "threads",
                                                   "scene",
                                                   "scene_triangles",
                                                   "frame",
                                                   "builder",
                                                   "builder_params",
                                                   "layout",
                                                   "build_ms_median",
                                                   "build_ms_min",
                                                   "build_ms_max",
                                                   "build_reps",
                                                   "layout_ms",
                                                   "mem_bytes",
                                                   "mem_peak_bytes",
                                                   "nodes",
                                                   "leaves",
                                                   "arity",
                                                   "max_depth",
                                                   "refs_per_prim",
                                                   "sah_cost",
                                                   "sah_c_trav",
                                                   "sah_c_isect",
                                                   "ray_set",
                                                   "ray_count",
                                                   "trace_mrays_median",
                                                   "trace_mrays_min",
                                                   "trace_mrays_max",
                                                   "trace_reps",
                                                   "nodes_per_ray",
                                                   "prims_per_ray",
                                                   "reference",
                                                   "mismatches",
                                                   "run_fingerprint",
                                                   "build_ms_samples",
                                                   "trace_mrays_samples",
                                                   "build_layout_ms_median",
                                                   "hit_fraction"};
  return columns;
}

std::optional<double> csv_number(const CsvRow& row, const std::string& column) {
  const auto it = row.find(column);
  if (it == row.end() || it->second.empty()) return std::nullopt;
  try {
    return std::stod(it->second);
  } catch (const std::exception&) {
    return std::nullopt;
  }
}

std::string csv_escape(const std::string& field) {
  if (field.find_first_of(",\"\n\r") == std::string::npos) return field;
  std::string out = "\"";
  for (char c : field) out += c == '"' ? std::string("\"\"") : std::string(1, c);
  return out + "\"";
}

CsvWriter::CsvWriter(std::filesystem::path path, std::vector<std::string> columns)
    : path_(std::move(path)), columns_(std::move(columns)) {
  require_file_path(path_, "result CSV");
  std::string text;
  if (std::filesystem::exists(path_)) text = read_text_file(path_, "result CSV");
  // A run killed mid-write leaves a partial last line: cut the file at its last complete line.
  if (!text.empty() && text.back() != '\n') {
    const std::size_t keep = text.rfind('\n') == std::string::npos ? 0 : text.rfind('\n') + 1;
    text.resize(keep);
    std::filesystem::resize_file(path_, keep);
    dropped_partial_row_ = true;
  }
  if (!text.empty()) {
    std::size_t pos = 0, line = 1;
    std::vector<std::string> header;
    next_record(text, pos, header, line, path_);
    for (std::size_t i = 0; i < std::max(header.size(), columns_.size()); ++i) {
      const std::string have = i < header.size() ? header[i] : "(none)";
      const std::string want = i < columns_.size() ? columns_[i] : "(none)";
      if (have != want)
        throw Error(path_.string() + ": existing header differs at column " + std::to_string(i + 1) + ": '" +
                    have + "', this version writes '" + want + "'; write to a new file");
    }
  }
  if (path_.has_parent_path()) std::filesystem::create_directories(path_.parent_path());
  out_.open(path_, std::ios::app);
  if (!out_) throw Error(path_.string() + ": cannot open for writing");
  if (text.empty()) {
    for (std::size_t i = 0; i < columns_.size(); ++i) out_ << (i ? "," : "") << csv_escape(columns_[i]);
    out_ << '\n' << std::flush;
  }
}

void CsvWriter::append(const CsvRow& row) {
  for (const auto& [key, value] : row)
    if (std::find(columns_.begin(), columns_.end(), key) == columns_.end())
      throw Error(path_.string() + ": row has column '" + key + "' that the header lacks");
  std::string line;
  for (std::size_t i = 0; i < columns_.size(); ++i) {
    const auto it = row.find(columns_[i]);
    if (i) line += ',';
    if (it != row.end()) line += csv_escape(it->second);
  }
  out_ << line << '\n' << std::flush;
  if (!out_) throw Error(path_.string() + ": write failed");
}

std::vector<CsvRow> read_csv(const std::filesystem::path& path) {
  std::string text = read_text_file(path, "result CSV");
  std::size_t pos = 0, line = 1;
  std::vector<std::string> header, fields;
  std::vector<CsvRow> rows;
  // Only complete lines: a trailing partial row is one being written or cut off by a crash.
  text.resize(text.rfind('\n') == std::string::npos ? 0 : text.rfind('\n') + 1);
  // Comment lines before the header ('#', as `sahbench trace` writes what answered) are not records.
  while (pos < text.size() && text[pos] == '#') {
    pos = text.find('\n', pos) + 1;
    ++line;
  }
  if (!next_record(text, pos, header, line, path)) return rows;
  while (true) {
    const std::size_t row_line = line;
    if (!next_record(text, pos, fields, line, path)) break;
    if (fields.size() == 1 && fields[0].empty()) continue;  // blank line
    if (fields.size() != header.size())
      throw Error(path.string() + ":" + std::to_string(row_line) + ": " + std::to_string(fields.size()) +
                  " fields, the header has " + std::to_string(header.size()));
    CsvRow row;
    for (std::size_t i = 0; i < header.size(); ++i) row[header[i]] = fields[i];
    rows.push_back(std::move(row));
  }
  return rows;
}

}  // namespace sahbench
