#include "socketsmith/pipeline/brim_figure.h"

#include <cmath>

#include <fmt/format.h>

#include "socketsmith/core/units.h"
#include "socketsmith/design/brim.h"
#include "socketsmith/design/spots.h"
#include "socketsmith/report/svg_plot.h"
#include "socketsmith/volume/limb_generator.h"
#include "socketsmith/volume/limb_model.h"

namespace socketsmith::pipeline {

std::vector<report::Plot> brim_template_plots(std::uint64_t seed) {
  using design::BrimTemplate;
  using geometry::LimbType;
  const std::vector<std::pair<LimbType, std::vector<BrimTemplate>>> groups = {
      {LimbType::Transtibial,
       {BrimTemplate::Ptb, BrimTemplate::PtbSc, BrimTemplate::PtbScsp, BrimTemplate::Kbm, BrimTemplate::Tsb}},
      {LimbType::Transfemoral, {BrimTemplate::Quad, BrimTemplate::Ics}}};
  const double deg = units::deg, mm = units::mm;
  // Landmark colours (Okabe–Ito), one per code in order.
  const std::vector<std::string> colours = {"#E69F00", "#56B4E9", "#009E73", "#F0E442",
                                            "#CC79A7", "#D55E00", "#999999", "#000000"};
  std::vector<report::Plot> panels;
  for (const auto& [type, kinds] : groups) {
    const volume::GeneratedLimb g = volume::generate_limb(volume::default_params(type, seed));
    volume::LimbInputOptions lo;
    lo.type = type;
    const volume::LimbModel model = volume::prepare_limb(volume::merge_shells(g), {}, lo);
    for (const BrimTemplate kind : kinds) {
      const design::BrimLine brim = design::make_brim(kind, model);
      report::Plot p;
      p.title = fmt::format("{} {} (generated limb, seed {})", geometry::to_string(type), design::to_string(kind), seed);
      p.x_label = "theta [deg] (0 anterior, +90 medial, -90 lateral, ±180 posterior)";
      p.y_label = "h [mm]";
      p.x_min = -180;
      p.x_max = 180;
      p.width_px = 520;
      p.height_px = 520;  // tall enough that the legend stays under the brim
      p.y_min = 0;
      p.y_max = 50 * std::ceil((model.cut_height_m / mm + 20) / 50);
      p.legend = report::LegendPosition::BottomLeft;
      report::PlotSeries line{"brim", {}, {}, "#0072B2"};
      for (int k = -180; k <= 180; ++k) {
        line.x.push_back(k);
        line.y.push_back(brim.height(k * deg) / mm);
      }
      report::PlotSeries keys{"key points", {}, {}, "#0072B2"};
      keys.markers = true;
      keys.line_width = 0;
      for (const auto& kp : brim.key_points()) {
        keys.x.push_back(design::wrap_angle(kp.theta) / deg);
        keys.y.push_back(kp.h / mm);
      }
      report::PlotSeries cut{"cut", {-180, 180}, {model.cut_height_m / mm, model.cut_height_m / mm}, "#555555"};
      cut.dashed = true;
      cut.line_width = 1;
      p.series = {line, keys, cut};
      for (size_t i = 0; i < model.landmarks.size(); ++i) {
        const auto& l = model.landmarks[i];
        report::PlotSeries m{l.code, {l.cylindrical.theta / deg}, {l.cylindrical.h / mm}, colours[i % colours.size()]};
        m.markers = true;
        m.line_width = 0;
        p.series.push_back(m);
      }
      panels.push_back(std::move(p));
    }
  }
  return panels;
}

void write_brim_template_figure(const std::filesystem::path& path, std::uint64_t seed) {
  report::write_svg_grid(path, brim_template_plots(seed), 2);
}

}  // namespace socketsmith::pipeline
