#include "socketsmith/report/compare_report.h"

#include "socketsmith/core/atomic_file.h"
#include "socketsmith/core/errors.h"
#include "socketsmith/report/html.h"

namespace socketsmith::report {

std::string render_compare_html(const CompareReportData& d) {
  require(!d.slices.rows.empty(), "render_compare_html: the slice table has no levels");
  const std::string map_uri = png_data_uri(render_pressure_map(d.map));  // any error before a byte is written
  HtmlWriter h(d.title);
  if (!d.generated.empty()) h.paragraph(d.generated);
  h.heading("Shapes");
  h.table({{"A (reference)", d.a_file}, {"B (aligned onto A)", d.b_file}});
  if (!d.notes.empty()) {
    h.raw("<ul>\n");
    for (const auto& n : d.notes) {
      h.raw("<li>");
      h.text(n);
      h.raw("</li>\n");
    }
    h.raw("</ul>\n");
  }
  h.heading("Alignment");
  h.table(d.alignment);
  h.heading("Deviation map (B − A)");
  h.image(map_uri, d.map.title, d.map_caption);
  h.table(d.deviation);
  h.heading("Volumes");
  h.table(d.volumes);
  append_slice_section(h, d.slices);
  return h.finish();
}

void write_compare_html(const std::filesystem::path& path, const CompareReportData& data) {
  const std::string html = render_compare_html(data);
  write_text_atomically(path, html);
}

}  // namespace socketsmith::report
