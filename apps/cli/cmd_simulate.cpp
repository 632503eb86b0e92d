// `socketsmith simulate cube`: the thesis's cube experiment (Figs. 28–30).
#include <cmath>
#include <filesystem>
#include <map>

#include "cli_common.h"
#include "socketsmith/core/atomic_file.h"
#include "socketsmith/core/errors.h"
#include "socketsmith/core/log.h"
#include "socketsmith/report/csv.h"
#include "socketsmith/report/svg_plot.h"
#include "socketsmith/tissue/cube_experiment.h"

namespace socketsmith::cli {
namespace {

struct CubeFlags {
  ModelFlags model;
  std::string out;
  bool json = false;
  int divisions = 8;
  int weights = 17;
  double max_weight = 80.0;
  double edge_mm = 50.0;
};

nlohmann::json finite_or_null(double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(); }

nlohmann::json rows_json(const tissue::CubeExperimentResult& r) {
  nlohmann::json rows = nlohmann::json::array();
  for (const auto& row : r.rows)
    rows.push_back({{"weight_n", row.weight_n},
                    {"top_pressure_analytic_pa", row.top_pressure_analytic_pa},
                    {"top_pressure_pa", row.top_pressure_pa},
                    {"top_pressure_true_pa", row.top_pressure_true_pa},
                    {"nodal_pressure_spread", row.nodal_pressure_spread},
                    {"displacement_ratio_analytic", row.displacement_ratio_analytic},
                    {"displacement_ratio", row.displacement_ratio},
                    {"displacement_ratio_reference", finite_or_null(row.displacement_ratio_reference)},
                    {"volume_ratio_reference", finite_or_null(row.volume_ratio_reference)},
                    {"volume_ratio", row.volume_ratio},
                    {"lateral_stretch", row.lateral_stretch},
                    {"newton_iterations", row.newton_iterations},
                    {"min_stiffness_eigenvalue_n_per_m",
                     finite_or_null(row.min_stiffness_eigenvalue)}});
  return rows;
}

std::vector<std::vector<double>> csv_rows(const tissue::CubeExperimentResult& r) {
  std::vector<std::vector<double>> rows;
  for (const auto& row : r.rows)
    rows.push_back({row.weight_n, row.top_pressure_analytic_pa, row.top_pressure_pa, row.displacement_ratio_analytic,
                    row.displacement_ratio, row.volume_ratio, row.displacement_ratio_reference,
                    row.volume_ratio_reference});
  return rows;
}

void run_cube(const CubeFlags& f) {
  namespace fs = std::filesystem;
  const fs::path out(f.out);
  ensure_directory(out);
  tissue::CubeExperimentOptions base;
  base.edge_m = f.edge_mm * 1e-3;
  base.divisions = f.divisions;
  base.num_weights = f.weights;
  base.max_weight_n = f.max_weight;
  base.material = make_material(f.model);
  base.check_stability = f.divisions <= 4;  // dense eigenvalues: small lattices only

  // The selected configuration, then the references shown beside it in the plot.
  struct Config {
    std::string label;
    tissue::MassSpringOptions options;
  };
  std::vector<Config> configs;
  const tissue::MassSpringOptions selected = make_model_options(f.model);
  const bool custom = f.model.golec_a >= 0 || f.model.alpha >= 0 || f.model.c >= 0 || f.model.beta >= 0 || f.model.spring_ratio >= 0 ||
                      !f.model.law.empty();
  auto label_of = [&](const tissue::MassSpringOptions& o, const std::string& preset) {
    if (o.kind != tissue::TissueModelKind::MssCs) return tissue::to_string(o.kind);
    return "mss-cs (" + preset + ")";
  };
  configs.push_back({label_of(selected, custom ? "custom" : f.model.constants), selected});
  for (const auto& [kind, preset] : std::vector<std::pair<tissue::TissueModelKind, std::string>>{
           {tissue::TissueModelKind::MssCs, "recommended"},
           {tissue::TissueModelKind::MssCs, "thesis"},
           {tissue::TissueModelKind::MssCf, ""},
           {tissue::TissueModelKind::Mss, ""}}) {
    tissue::MassSpringOptions o;
    o.kind = kind;
    o.corrective = tissue::CorrectiveSpringConstants::preset(kind == tissue::TissueModelKind::MssCs ? preset : "thesis");
    o.cf_poisson_ratio = f.model.cf_poisson;
    const std::string label = label_of(o, preset);
    bool seen = false;
    for (const auto& c : configs) seen |= c.label == label;
    if (!seen) configs.push_back({label, o});
  }

  nlohmann::json summary;
  std::vector<std::pair<std::string, tissue::CubeExperimentResult>> results;
  for (size_t i = 0; i < configs.size(); ++i) {
    tissue::CubeExperimentOptions o = base;
    o.model = configs[i].options;
    log::info("cube experiment: {} ({}^3 elements, {} weights up to {} N)", configs[i].label, f.divisions, f.weights,
              f.max_weight);
    auto r = tissue::run_cube_experiment(o, console_progress(1.0));
    if (i == 0 && !r.converged) fail<SolverError>("simulate cube: {} (try --divisions 4 or a smaller --max-weight)", r.message);
    if (!r.converged) log::warn("simulate cube: reference {} stopped early: {}", configs[i].label, r.message);
    const auto err = tissue::cube_errors(r);
    summary["models"].push_back({{"label", configs[i].label},
                                 {"options", to_json(configs[i].options, base.material)},
                                 {"converged", r.converged},
                                 {"message", r.message},
                                 {"max_displacement_error_to_60pct", err.max_displacement_error},
                                 {"max_volume_error_to_40pct", err.max_volume_error},
                                 {"unstable_before_60pct", err.unstable},
                                 {"max_displacement_error_vs_own_energy", finite_or_null(err.max_displacement_error_reference)},
                                 {"max_volume_error_vs_own_energy", finite_or_null(err.max_volume_error_reference)},
                                 {"wall_s", r.wall_s},
                                 {"rows", rows_json(r)}});
    results.emplace_back(configs[i].label, std::move(r));
  }

  // *_reference: the uniaxial stress state of the model's own energy (continuum models; nan otherwise).
  const std::vector<std::string> header = {"weight_n", "top_pressure_analytic_pa", "top_pressure_pa",
                                           "displacement_ratio_analytic", "displacement_ratio", "volume_ratio",
                                           "displacement_ratio_reference", "volume_ratio_reference"};
  report::write_csv(out / "cube.csv", header, csv_rows(results.front().second));
  std::vector<std::vector<double>> all_rows;
  {
    std::vector<std::string> h = header;
    h.insert(h.begin(), "model_index");
    for (size_t m = 0; m < results.size(); ++m)
      for (auto row : csv_rows(results[m].second)) {
        row.insert(row.begin(), static_cast<double>(m));
        all_rows.push_back(row);
      }
    report::write_csv(out / "cube_all.csv", h, all_rows);
  }

  // Plot like the thesis's Figs. 28–30.
  report::Plot pressure{"Top pressure (Fig. 28)", "box weight [N]", "pressure [kPa]", {}, {}, {}, {}, {}};
  report::Plot disp{"Displacement ratio (Fig. 29)", "box weight [N]", "displacement / edge", {}, {}, {}, {}, {}};
  report::Plot vol{"Volume (Fig. 30)", "box weight [N]", "volume [cm^3]", {}, {}, {}, {}, {}};
  const auto& first = results.front().second;
  report::PlotSeries an_p{"analytic W/A", {}, {}, "#000000", true, false, 2};
  report::PlotSeries an_d{"analytic W/(AE)", {}, {}, "#000000", true, false, 2};
  report::PlotSeries an_v{"initial volume", {}, {}, "#000000", true, false, 2};
  const double v0_cm3 = std::pow(f.edge_mm / 10.0, 3);
  // The analytic uniaxial state of the selected continuum model's own energy, where it has one.
  report::PlotSeries ref_d{results.front().first + ", analytic", {}, {}, "#555555", true, false, 1}, ref_v = ref_d;
  for (const auto& row : first.rows) {
    an_p.x.push_back(row.weight_n);
    an_p.y.push_back(row.top_pressure_analytic_pa / 1e3);
    an_d.x.push_back(row.weight_n);
    an_d.y.push_back(row.displacement_ratio_analytic);
    an_v.x.push_back(row.weight_n);
    an_v.y.push_back(v0_cm3);
    if (!std::isfinite(row.displacement_ratio_reference)) continue;
    ref_d.x.push_back(row.weight_n);
    ref_d.y.push_back(row.displacement_ratio_reference);
    ref_v.x.push_back(row.weight_n);
    ref_v.y.push_back(row.volume_ratio_reference * v0_cm3);
  }
  pressure.series.push_back(an_p);
  disp.series.push_back(an_d);
  vol.series.push_back(an_v);
  if (!ref_d.x.empty()) {
    disp.series.push_back(ref_d);
    vol.series.push_back(ref_v);
  }
  for (const auto& [label, r] : results) {
    report::PlotSeries sp{label, {}, {}, "", false, true, 2}, sd = sp, sv = sp;
    for (const auto& row : r.rows) {
      sp.x.push_back(row.weight_n);
      sp.y.push_back(row.top_pressure_pa / 1e3);
      sd.x.push_back(row.weight_n);
      sd.y.push_back(row.displacement_ratio);
      sv.x.push_back(row.weight_n);
      sv.y.push_back(row.volume_ratio * v0_cm3);
    }
    pressure.series.push_back(sp);
    disp.series.push_back(sd);
    vol.series.push_back(sv);
  }
  report::write_svg_grid(out / "cube.svg", {pressure, disp, vol}, 3);

  summary["command"] = "socketsmith simulate cube";
  summary["edge_m"] = base.edge_m;
  summary["divisions"] = f.divisions;
  summary["nodes"] = first.num_nodes;
  summary["elements"] = first.num_elements;
  summary["selected"] = summary["models"][0];
  summary["outputs"] = {(out / "cube.csv").string(), (out / "cube_all.csv").string(), (out / "cube.svg").string(),
                        (out / "summary.json").string()};
  write_text_atomically(out / "summary.json", summary.dump(2) + "\n");
  const auto err = tissue::cube_errors(first);
  log::info("{}: max displacement error {:.2f}% (to 60% strain), max volume error {:.2f}% (to 40% strain)",
            results.front().first, 100 * err.max_displacement_error, 100 * err.max_volume_error);
  if (std::isfinite(err.max_displacement_error_reference))
    log::info("{}: against the analytic uniaxial state of its own energy (every weight solved): max displacement error "
              "{:.3g}%, max volume error {:.3g}% of V0",
              results.front().first, 100 * err.max_displacement_error_reference, 100 * err.max_volume_error_reference);
  log::info("wrote {}", (out / "cube.csv").string());
  if (f.json) print_json(summary["selected"]);
}

}  // namespace

void register_simulate(CLI::App& app) {
  auto* sim = app.add_subcommand("simulate", "run a simulation scenario");
  sim->require_subcommand(1);
  auto flags = std::make_shared<CubeFlags>();
  auto* cube = sim->add_subcommand("cube", "the thesis's cube experiment: a rigid box of 0-80 N on a 50 mm cube");
  add_model_flags(*cube, flags->model);
  cube->add_option("--out", flags->out, "output folder (cube.csv, cube_all.csv, cube.svg, summary.json)")->required();
  cube->add_flag("--json", flags->json, "print the selected model's summary as JSON on stdout");
  cube->add_option("--divisions", flags->divisions, "elements per cube edge")->check(CLI::Range(1, 60));
  cube->add_option("--weights", flags->weights, "number of weights from 0 to --max-weight")->check(CLI::Range(2, 1000));
  cube->add_option("--max-weight", flags->max_weight, "heaviest box [N]")->check(positive());
  cube->add_option("--edge-mm", flags->edge_mm, "cube edge [mm]")->check(positive());
  cube->callback([flags] { run_cube(*flags); });
}

}  // namespace socketsmith::cli
