// The design report as one self-contained HTML page: the warnings, the patient and inputs, the
// constraints with the radar chart, comfort, load by region, maps, profiles, the socket, the
// prosthetist's checks, the delivered pressures and the runs (design_report_detail.h says why this
// is apart).
#include <algorithm>
#include <cmath>
#include <limits>

#include <fmt/format.h>

#include "socketsmith/core/errors.h"
#include "socketsmith/report/design_report.h"
#include "socketsmith/report/design_report_detail.h"
#include "socketsmith/core/atomic_file.h"
#include "socketsmith/report/svg_plot.h"

namespace socketsmith::report {
using namespace design_report_detail;
namespace {

// A value below 1e-9 of its display unit is round-off (an optimised angle of 5.8e-17°, an amplitude
// of 9.4e-17 kPa: the browser showed them as such): shown as 0.
double shown(double v) { return std::abs(v) < 1e-9 ? 0.0 : v; }
std::string deg(double rad) { return num(shown(rad * 180 / kPi)); }
std::string mm(double m) { return num(shown(m * 1e3)); }
std::string kpa(double pa) { return num(shown(pa * 1e-3)); }

std::string spot_theta(const ReportSpot& s) {
  if (s.type == "cos2" || s.type == "cos-sig")
    return fmt::format("θ0 {} ± {}", deg(s.theta0_rad), deg(s.r_theta_rad));
  if (s.type == "sig2")
    return fmt::format("{} … {} (λ {} /°)", deg(s.theta1_rad), deg(s.theta2_rad),
                       num(s.lambda_theta_per_rad * kPi / 180));
  return "all";
}

std::string spot_height(const ReportSpot& s) {
  if (s.type == "cos2") return fmt::format("h0 {} ± {}", mm(s.h0_m), mm(s.r_h_m));
  if (s.type == "sig2" || s.type == "cos-sig")
    return fmt::format("{} … {} (λ {} /mm)", mm(s.h1_m), mm(s.h2_m), num(s.lambda_h_per_m * 1e-3));
  if (s.type == "grad") return fmt::format("full below {}, none above {}", mm(s.h1_m), mm(s.h2_m));
  return "";
}

}  // namespace

std::string html_escape(std::string_view text) { return escape_markup(text, "&#39;", false); }

std::string base64_encode(std::string_view bytes) {
  static constexpr char kAlphabet[] =
      "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  out.reserve((bytes.size() + 2) / 3 * 4);
  std::size_t i = 0;
  auto byte = [&](std::size_t k) { return static_cast<std::uint32_t>(static_cast<unsigned char>(bytes[k])); };
  for (; i + 3 <= bytes.size(); i += 3) {
    const std::uint32_t v = byte(i) << 16 | byte(i + 1) << 8 | byte(i + 2);
    out += kAlphabet[v >> 18 & 63];
    out += kAlphabet[v >> 12 & 63];
    out += kAlphabet[v >> 6 & 63];
    out += kAlphabet[v & 63];
  }
  const std::size_t rest = bytes.size() - i;
  if (rest > 0) {
    std::uint32_t v = byte(i) << 16;
    if (rest == 2) v |= byte(i + 1) << 8;
    out += kAlphabet[v >> 18 & 63];
    out += kAlphabet[v >> 12 & 63];
    out += rest == 2 ? kAlphabet[v >> 6 & 63] : '=';
    out += '=';
  }
  return out;
}

namespace {

void rectification_section(HtmlWriter& h, const ReportRectification& r) {
  if (!r.has_rectification) return;
  h.heading("Rectification chart (socket minus limb)");
  h.paragraph("How far " + r.source +
              " lies from the limb's skin, in mm, along the ray from the limb axis (radially), or along the axis where "
              "the skin faces down (the distal end): negative = indentation (the socket presses the tissue in), "
              "positive = relief. Below the brim: mean " + mm(r.mean_m) + " mm, from " + mm(r.min_m) + " to " +
              mm(r.max_m) + " mm.");
  std::vector<std::vector<std::string>> rows;
  for (const auto& p : r.landmarks) {
    const double d = p.rectification_m;
    const bool has = std::isfinite(d);
    rows.push_back({p.code, p.name, deg(p.theta_rad), mm(p.h_m), has ? num(d * 1e3, 2) : "above the brim",
                    has ? (d < 0 ? "indentation" : "relief") : "—", p.is_axial ? "along the axis" : "radial"});
  }
  h.table({"landmark", "zone", "θ [°]", "h [mm]", "socket − limb [mm]", "", "measured"}, rows);
  if (r.has_map)
    h.image(png_data_uri(render_pressure_map(r.map)), r.map.title,
            "Blue: the socket inside the skin (indentation); red: outside (relief); grey: above the brim.");
}

void sock_ply_section(HtmlWriter& h, const ReportSockPly& s) {
  if (!s.has_study) return;
  h.heading("Sock-ply sensitivity (the limb shrunk and grown)");
  h.paragraph(s.summary);
  std::vector<std::vector<std::string>> rows;
  for (const auto& l : s.levels) {
    const std::string name = l.volume_change == 0 ? "as designed" : fmt::format("{:+.0f} %", 100 * l.volume_change);
    rows.push_back({name, num(l.skin_offset_m * 1e3, 2), l.stood ? num(l.stood_offset_m * 1e3, 3) : "—",
                    l.stood ? num(l.sink_m * 1e3, 3) : "—", l.stood ? num(l.peak_ratio, 3) : "—",
                    l.stood ? kpa(l.peak_pressure_pa) : "—", l.stood ? kpa(l.distal_mean_pa) : "—",
                    l.stood ? kpa(l.distal_peak_pa) : "—", l.stood ? l.constraints : l.message});
  }
  h.table({"limb volume", "skin offset [mm]", "socket stood at [mm]", "limb sinks [mm]", "peak p/T", "peak [kPa]",
           "distal mean [kPa]", "distal peak [kPa]", "constraints"},
          rows);
  h.paragraph("Skin offset: the uniform normal offset of the skin (bones fixed) that changes the limb's volume by the "
              "given fraction. Socket stood at: where the socket carried half the body weight, along the axis from its "
              "designed pose. Limb sinks: how much deeper than at the designed volume the limb sits in the socket "
              "(negative: it rises). Peak p/T: the largest contact pressure over the pain threshold below the brim. Distal: "
              "the contact pressure over the distal fifth of the stump. Constraints: the design's seven conditions and "
              "comfort (p/T ≤ 1) evaluated on the delivered pressures with the design's tolerances (a failing one is "
              "shown with its value and target: a donned socket delivers the design only approximately, so compare "
              "with the row 'as designed').");
  for (const auto& m : s.maps) h.image(png_data_uri(render_pressure_map(m)), m.title);
  for (const auto& p : s.plots) h.image(svg_data_uri(render_svg(p)), p.title);
}

/// What the reader must check first.
void warnings_section(HtmlWriter& h, const DesignReportData& d) {
  if (d.warnings.empty()) return;
  h.heading("Warnings");
  h.raw("<ul class=\"warn\">\n");
  for (const auto& w : d.warnings) {
    h.raw("<li>");
    h.text(w);
    h.raw("</li>\n");
  }
  h.raw("</ul>\n");
}

/// The patient: masses, tissue stiffness, friction, note.
void patient_section(HtmlWriter& h, const DesignReportData& d) {
  const ReportPatient& p = d.patient;
  h.heading("Patient");
  std::vector<std::pair<std::string, std::string>> patient;
  if (!p.id.empty()) patient.push_back({"patient", p.id});
  patient.push_back({"body mass", num(p.body_mass_kg) + " kg"});
  patient.push_back({"prosthesis mass", num(p.prosthesis_mass_kg) + " kg"});
  patient.push_back({"tissue Young's modulus E", kpa(p.tissue_youngs_modulus_pa) + " kPa"});
  patient.push_back({"friction coefficient μ (skin–socket)", num(p.friction)});
  h.table(patient);
  if (!p.note.empty()) h.paragraph(p.note, "note");
}

/// The limb, the mesh, the tissue model, the spots and the brim.
void inputs_section(HtmlWriter& h, const DesignReportData& d) {
  h.heading("Inputs");
  h.table({{"limb file", d.limb_file.empty() ? "—" : d.limb_file},
           {"limb", (d.limb_type.empty() ? std::string("—") : d.limb_type) +
                        (d.side.empty() ? std::string() : ", " + d.side)},
           {"mesh nodes", d.mesh_nodes > 0 ? std::to_string(d.mesh_nodes) : "—"},
           {"tissue model", d.model.empty() ? "—" : d.model},
           {"brim template", d.brim_template.empty() ? "—" : d.brim_template}});
  if (!d.spots.empty()) {
    h.heading("Pressure spots", 3);
    std::vector<std::vector<std::string>> rows;
    for (const auto& s : d.spots)
      rows.push_back({s.name, s.type, kpa(s.amplitude_pa), spot_theta(s), spot_height(s), s.is_enabled ? "yes" : "no"});
    h.table({"name", "type", "A [kPa]", "θ [°]", "h [mm]", "enabled"}, rows);
    h.paragraph("θ: 0° anterior, +90° medial, 180° posterior; h above the distal end.");
  }
  if (!d.brim_key_points.empty()) {
    h.heading("Brim key points", 3);
    std::vector<std::vector<std::string>> rows;
    for (const auto& k : d.brim_key_points) rows.push_back({deg(k.theta_rad), mm(k.h_m)});
    h.table({"θ [°]", "h [mm]"}, rows);
  }
}

/// The seven constraints: the radar chart and each value against its target.
void constraints_section(HtmlWriter& h, const DesignReportData& d) {
  if (d.radar.axes.empty()) return;
  const int met = radar_axes_met(d.radar.axes);
  const int n = static_cast<int>(d.radar.axes.size());
  h.heading("Constraints");
  h.raw("<p><strong>");
  h.text(met == n ? std::string("all constraints met") : fmt::format("{} of {} met", met, n));
  h.raw("</strong></p>\n");
  h.image(png_data_uri(render_radar_chart(d.radar)), "radar chart of the constraints");
  h.raw("<table>\n");
  h.row({"constraint", "value", "target", "normalised r", "status"}, true);
  for (const auto& a : d.radar.axes) {
    const std::string unit = a.unit.empty() ? "" : " " + a.unit;
    const std::string target = a.is_lower_bound ? "≥ " + num(a.target) + unit
                                                : num(a.target) + " ± " + num(a.tolerance) + unit;
    h.row({a.name, num(a.value) + unit, target, num(radar_radius(a)), a.is_ok ? "pass" : "FAIL"}, false,
          a.is_ok ? "ok" : "fail");
  }
  h.raw("</table>\n");
  h.paragraph("Radius r = 1 + (value − target) / scale: the target circle is r = 1 for every axis; scale = M g / 2 "
              "for forces and stability, M g / 2 × stump length for torques.");
}

/// The largest pressure and pressure / threshold, and where it is.
void comfort_section(HtmlWriter& h, const DesignReportData& d) {
  std::string where = "—";
  if (d.has_max_ratio_position) {
    const auto& lms = !d.landmarks.empty() ? d.landmarks
                                           : (d.maps.empty() ? d.landmarks : d.maps.front().landmarks);
    double best = std::numeric_limits<double>::infinity();
    for (const auto& lm : lms) {
      const double dist = (lm.position - d.max_ratio_position).norm();
      if (dist < best) {
        best = dist;
        where = fmt::format("nearest landmark zone {} ({} mm away)", lm.code, mm(dist));
      }
    }
    if (lms.empty())
      where = fmt::format("at ({}, {}, {}) mm", mm(d.max_ratio_position.x()), mm(d.max_ratio_position.y()),
                          mm(d.max_ratio_position.z()));
  }
  h.heading("Comfort");
  h.table({{"largest applied pressure", kpa(d.max_pressure_pa) + " kPa"},
           {"largest pressure / pain threshold",
            num(d.max_pressure_ratio) + (d.max_pressure_ratio > 1 ? " (above the threshold)" : "")},
           {"where", where}});
}

/// The axial load shared by the regions.
void region_load_section(HtmlWriter& h, const DesignReportData& d) {
  if (d.region_loads.empty()) return;
  h.raw("<h2>Axial load by region</h2>\n<table>\n");
  h.row({"region", "share of F_z", "axial [N]", "of which friction [N]", "loaded area [cm²]", "mean [kPa]",
         "peak [kPa]"},
        true);
  for (const auto& r : d.region_loads)
    h.row({r.name, num(100 * r.share) + " %", num(r.axial_n), num(r.friction_n), num(r.area_m2 * 1e4),
           kpa(r.mean_pressure_pa), kpa(r.peak_pressure_pa)},
          false, r.is_highlighted ? "ok" : "");
  h.raw("</table>\n<p>");
  h.text("Axial: the normal forces' component along the limb axis plus the available friction μ p A cos θ "
         "(the thesis's F_z, eq. 42), summed over the region's skin below the brim." +
         (d.region_note.empty() ? std::string() : " " + d.region_note));
  h.raw("</p>\n");
}

/// The pressure maps and the profiles along the paths.
void maps_and_profiles_section(HtmlWriter& h, const DesignReportData& d) {
  if (!d.maps.empty()) {
    h.heading("Pressure maps");
    for (const auto& m : d.maps) {
      h.heading(m.title, 3);
      h.image(png_data_uri(render_pressure_map(m)), m.title);
    }
    h.paragraph("Views: anterior, medial, posterior, lateral. Grey: no pressure (above the brim). White markers: "
                "landmarks given; magenta: placed automatically.");
  }

  if (!d.profiles.empty()) {
    h.heading("Pressure along paths");
    for (const auto& pr : d.profiles) h.image(svg_data_uri(render_svg(path_profile_plot(pr))), pr.name);
  }
}

/// The socket: file, wall, volumes, thickness map and circumferences.
void socket_section(HtmlWriter& h, const DesignReportData& d) {
  const ReportSocket& s = d.socket;
  h.heading("Socket");
  if (!s.has_socket) {
    h.paragraph("No socket built.");
  } else {
    std::vector<std::pair<std::string, std::string>> rows;
    if (!s.stl_file.empty()) rows.push_back({"socket file", s.stl_file});
    rows.push_back({"wall thickness", mm(s.thickness_m) + " mm"});
    if (s.max_thickness_m > 0)
      rows.push_back({"measured wall (min / median / max)",
                      mm(s.min_thickness_m) + " / " + mm(s.median_thickness_m) + " / " + mm(s.max_thickness_m) + " mm"});
    for (const auto& kv : s.details) rows.push_back(kv);
    rows.push_back({"limb volume (below the brim)", num(s.limb_volume_m3 * 1e6) + " cm³"});
    rows.push_back({"socket inner volume", num(s.socket_volume_m3 * 1e6) + " cm³"});
    if (s.limb_volume_m3 > 0)
      rows.push_back({"volume reduction", num(100 * (s.limb_volume_m3 - s.socket_volume_m3) / s.limb_volume_m3) + " %"});
    h.table(rows);
    if (s.has_thickness_map)
      h.image(png_data_uri(render_pressure_map(s.thickness_map)), "wall thickness",
              "Wall thickness: the distance from each point of the outer surface to the inner wall (grey: the inner "
              "wall). The minimum leaves out the rounded brim edge.");
    if (!s.circumferences.empty()) {
      std::vector<std::vector<std::string>> circ;
      for (const auto& c : s.circumferences)
        circ.push_back({mm(c.height_m), mm(c.limb_m), mm(c.socket_m),
                        c.limb_m > 0 ? num(100 * (c.limb_m - c.socket_m) / c.limb_m) : "—"});
      h.table({"h [mm]", "limb [mm]", "socket [mm]", "reduction [%]"}, circ);
    }
  }
}

/// The pressures the socket delivers once donned and stood on (closed loop).
void delivery_section(HtmlWriter& h, const DesignReportData& d) {
  const ReportDelivery& dl = d.delivery;
  if (dl.has_delivery) {
    h.heading("Delivered pressures (the socket donned and stood on)");
    h.paragraph(dl.summary);
    std::vector<std::vector<std::string>> rows;
    for (const auto& a : dl.rows)
      rows.push_back({a.region, a.stage, std::to_string(a.count), kpa(a.target_mean_pa), kpa(a.delivered_mean_pa),
                      kpa(a.mae_pa), kpa(a.p99_pa), kpa(a.max_error_pa), std::isfinite(a.r) ? num(a.r, 3) : "—",
                      kpa(a.target_sd_pa)});
    h.table({"region", "socket", "nodes", "designed mean [kPa]", "delivered mean [kPa]", "MAE [kPa]",
             "99th pct. error [kPa]", "max error [kPa]", "R", "designed SD [kPa]"},
            rows);
    if (!dl.details.empty()) h.table(dl.details);
    for (const auto& m : dl.maps) {
      h.heading(m.title, 3);
      h.image(png_data_uri(render_pressure_map(m)), m.title);
    }
    for (const auto& pl : dl.plots) h.image(svg_data_uri(render_svg(pl)), pl.title);
  }
}

/// A run (the optimiser, the solver): converged, iterations, residual, time and its details.
void run_section(HtmlWriter& h, const char* heading, const ReportRun& r) {
  h.heading(heading);
  if (!r.has_run) {
    h.paragraph("Not run.");
    return;
  }
  std::vector<std::pair<std::string, std::string>> rows{{"converged", r.converged ? "yes" : "no"},
                                                        {"iterations", std::to_string(r.iterations)},
                                                        {"residual", num(r.residual, 4)},
                                                        {"time", num(r.seconds) + " s"}};
  if (!r.message.empty()) rows.push_back({"message", r.message});
  for (const auto& kv : r.details) rows.push_back(kv);
  h.table(rows);
}

}  // namespace

std::string render_design_report_html(const DesignReportData& d) {
  HtmlWriter h(d.title);
  if (!d.generated.empty()) h.paragraph(d.generated);
  warnings_section(h, d);
  patient_section(h, d);
  inputs_section(h, d);
  constraints_section(h, d);
  comfort_section(h, d);
  region_load_section(h, d);
  maps_and_profiles_section(h, d);
  socket_section(h, d);
  rectification_section(h, d.rectification);
  if (!d.slices.rows.empty()) append_slice_section(h, d.slices);
  delivery_section(h, d);
  sock_ply_section(h, d.sock_ply);
  run_section(h, "Optimiser", d.optimiser);
  run_section(h, "Solver", d.solver);
  return h.finish();
}

void write_design_report_html(const std::filesystem::path& path, const DesignReportData& data) {
  const std::string html = render_design_report_html(data);  // any error: nothing written
  write_text_atomically(path, html);
}

}  // namespace socketsmith::report
