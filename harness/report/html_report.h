#pragma once
// `sahbench report --format html`: one self-contained page per run, which a CI job can keep as an
// artifact: the report's tables as HTML tables and the figures of scripts/plots.py embedded as data URIs
// (RFC 2397) in base64 (RFC 4648), so that the page needs no other file and no network.

#include <filesystem>
#include <iosfwd>
#include <string>
#include <string_view>

#include "harness/report/report_table.h"

namespace sahbench {

/// `bytes` in base64 with padding (RFC 4648, section 4).
std::string base64_encode(std::string_view bytes);

/// `text` with & < > " ' as character references.
std::string html_escape(std::string_view text);

/// The page's head (title, a small style sheet) and its heading with `subtitle` under it.
void html_begin(const std::string& title, const std::string& subtitle, std::ostream& out);

/// A section per table: heading, <table> with <caption>, the legend and notes as paragraphs. Best values
/// in <strong>, ratios as in Markdown ("(0.85 [0.80, 0.90] ▼)").
void render_html(const ReportTable& table, std::ostream& out);

/// A paragraph of plain text.
void html_paragraph(const std::string& text, std::ostream& out);

/// Every *.png and *.svg in `folder`, in name order, as an <img> with a data URI in a <figure> captioned
/// with its file name; an empty path writes nothing. A folder that does not exist is an Error naming it.
void html_figures(const std::filesystem::path& folder, std::ostream& out);

/// Closes the page.
void html_end(std::ostream& out);

}  // namespace sahbench
