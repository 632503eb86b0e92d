#pragma once
/// @file html.h
/// The pieces every socketsmith HTML page shares: one stylesheet (screen and print: A4 pages,
/// pictures and tables kept whole, headings kept with what follows), numbers formatted for people,
/// pictures embedded as data URIs, and a small writer of escaped text, tables and images. The
/// design report and the comparison page are built from them, so they look and print alike.

#include <sstream>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "socketsmith/report/raster.h"

namespace socketsmith::report {

/// @p v with about @p digits significant digits, without an exponent for ordinary magnitudes;
/// "n/a" when not finite.
std::string format_number(double v, int digits = 3);

/// A PNG data URI of @p img.
std::string png_data_uri(const Image& img);
/// An SVG data URI of the document @p svg.
std::string svg_data_uri(const std::string& svg);

/// An HTML document being written: escaped text, raw markup, table rows, images.
class HtmlWriter {
 public:
  /// Starts the document: doctype, <head> with @p title and the shared stylesheet, <body>, <h1>.
  explicit HtmlWriter(const std::string& title);
  void text(std::string_view s);  ///< escaped text
  void raw(std::string_view s);   ///< markup as is
  /// A table row of escaped cells (<th> when @p header), with an optional class.
  void row(const std::vector<std::string>& cells, bool header = false, std::string_view cls = "");
  void kv(const std::string& key, const std::string& value) { row({key, value}); }
  /// A <h2> (level 2) or <h3> heading.
  void heading(const std::string& title, int level = 2);
  /// A paragraph of escaped text.
  void paragraph(const std::string& s, std::string_view cls = "");
  /// A table of (key, value) rows.
  void table(const std::vector<std::pair<std::string, std::string>>& rows);
  /// A table with a header row.
  void table(const std::vector<std::string>& header, const std::vector<std::vector<std::string>>& rows);
  /// An <img> of @p uri (a data URI) with the escaped @p alt text, and a caption below when given.
  void image(const std::string& uri, const std::string& alt, const std::string& caption = "");
  /// Closes the document and returns it.
  std::string finish();

 private:
  std::ostringstream out_;
};

}  // namespace socketsmith::report
