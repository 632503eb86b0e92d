#include "socketsmith/report/html.h"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "socketsmith/report/design_report.h"

namespace socketsmith::report {
namespace {

// Screen: one readable column. Print (the patient file): A4 with 12 mm margins, the column as
// wide as the page, pictures and tables not split across pages, headings kept with what follows,
// colours printed as shown (the pass/fail cells, the colour bars).
constexpr const char* kStyle =
    "body{font-family:sans-serif;max-width:1100px;margin:1em auto;padding:0 1em;color:#222}\n"
    "h1{font-size:1.6em}h2{font-size:1.25em;border-bottom:1px solid #ccc;margin-top:1.6em}\n"
    "table{border-collapse:collapse;margin:.5em 0}td,th{border:1px solid #ccc;padding:.25em .6em;"
    "text-align:left}th{background:#f2f2f2}\n"
    "td.num,th.num{text-align:right}\n"
    "tr.ok td:last-child{color:#1e963c;font-weight:bold}tr.fail td:last-child{color:#d22828;"
    "font-weight:bold}\n"
    "img{max-width:100%;height:auto;display:block;margin:.5em 0}\n"
    "figure{margin:.5em 0}figcaption{font-size:.9em;color:#444}\n"
    ".warn{color:#a05a00}.note{white-space:pre-wrap;background:#fafafa;padding:.5em;border:1px "
    "solid #eee}\n"
    "@page{size:A4;margin:12mm}\n"
    "@media print{\n"
    "body{max-width:none;margin:0;padding:0;font-size:10pt}\n"
    "h1{font-size:16pt}h2{font-size:13pt;margin-top:1em}h2,h3{break-after:avoid;page-break-after:avoid}\n"
    "img,figure,table,tr{break-inside:avoid;page-break-inside:avoid}\n"
    "img{max-height:240mm;width:auto;max-width:100%}\n"
    "td,th{padding:.15em .4em}\n"
    "*{-webkit-print-color-adjust:exact;print-color-adjust:exact}\n"
    "}\n";

}  // namespace

std::string format_number(double v, int digits) {
  if (!std::isfinite(v)) return "n/a";
  if (v == 0) return "0";
  const double a = std::abs(v);
  if (a >= std::pow(10.0, digits) && a < 1e9) return fmt::format("{:.0f}", v);
  if (a >= 1e-3 && a < 1e9) {
    const int decimals = std::max(0, digits - 1 - static_cast<int>(std::floor(std::log10(a))));
    std::string s = fmt::format("{:.{}f}", v, decimals);
    if (s.find('.') != std::string::npos) {
      while (s.back() == '0') s.pop_back();
      if (s.back() == '.') s.pop_back();
    }
    return s;
  }
  return fmt::format("{:.{}g}", v, digits);
}

std::string png_data_uri(const Image& img) { return "data:image/png;base64," + base64_encode(encode_png(img)); }

std::string svg_data_uri(const std::string& svg) { return "data:image/svg+xml;base64," + base64_encode(svg); }

HtmlWriter::HtmlWriter(const std::string& title) {
  out_ << "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n<title>" << html_escape(title)
       << "</title>\n<style>\n"
       << kStyle << "</style>\n</head>\n<body>\n<h1>" << html_escape(title) << "</h1>\n";
}

void HtmlWriter::text(std::string_view s) { out_ << html_escape(s); }

void HtmlWriter::raw(std::string_view s) { out_ << s; }

void HtmlWriter::row(const std::vector<std::string>& cells, bool header, std::string_view cls) {
  out_ << (cls.empty() ? std::string("<tr>") : fmt::format("<tr class=\"{}\">", cls));
  for (const auto& c : cells) out_ << (header ? "<th>" : "<td>") << html_escape(c) << (header ? "</th>" : "</td>");
  out_ << "</tr>\n";
}

void HtmlWriter::heading(const std::string& title, int level) {
  out_ << "<h" << level << ">" << html_escape(title) << "</h" << level << ">\n";
}

void HtmlWriter::paragraph(const std::string& s, std::string_view cls) {
  out_ << (cls.empty() ? std::string("<p>") : fmt::format("<p class=\"{}\">", cls)) << html_escape(s) << "</p>\n";
}

void HtmlWriter::table(const std::vector<std::pair<std::string, std::string>>& rows) {
  out_ << "<table>\n";
  for (const auto& [k, v] : rows) kv(k, v);
  out_ << "</table>\n";
}

void HtmlWriter::table(const std::vector<std::string>& header, const std::vector<std::vector<std::string>>& rows) {
  out_ << "<table>\n";
  row(header, true);
  for (const auto& r : rows) row(r);
  out_ << "</table>\n";
}

void HtmlWriter::image(const std::string& uri, const std::string& alt, const std::string& caption) {
  out_ << "<figure><img alt=\"" << html_escape(alt) << "\" src=\"" << uri << "\">";
  if (!caption.empty()) out_ << "<figcaption>" << html_escape(caption) << "</figcaption>";
  out_ << "</figure>\n";
}

std::string HtmlWriter::finish() {
  out_ << "</body>\n</html>\n";
  return out_.str();
}

}  // namespace socketsmith::report
