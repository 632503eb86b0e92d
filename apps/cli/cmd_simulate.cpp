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

/// The experiment's settings shared by every model: the cube, its lattice, the weights and the
/// material.
tissue::CubeExperimentOptions cube_base_options(const CubeFlags& f) {
  tissue::CubeExperimentOptions base;
  base.edge_m = f.edge_mm * 1e-3;
  base.divisions = f.divisions;
  base.num_weights = f.weights;
  base.max_weight_n = f.max_weight;
  base.material = make_material(f.model);
  base.check_stability = f.divisions <= 4;  // dense eigenvalues: small lattices only
  return base;
}

/// A tissue model run in the experiment, with the label it has in the plot and the summary.
struct CubeConfig {
  std::string label;
  tissue::MassSpringOptions options;
};

/// The results of the models run, in the order of their configurations, with their labels.
using CubeResults = std::vector<std::pair<std::string, tissue::CubeExperimentResult>>;

std::string config_label(const tissue::MassSpringOptions& o, const std::string& preset) {
  if (o.kind != tissue::TissueModelKind::MssCs) return tissue::to_string(o.kind);
  return "mss-cs (" + preset + ")";
}

/// The selected configuration, then the references shown beside it in the plot (each label once).
std::vector<CubeConfig> cube_configs(const CubeFlags& f) {
  std::vector<CubeConfig> configs;
  const tissue::MassSpringOptions selected = make_model_options(f.model);
  const bool custom = f.model.golec_a >= 0 || f.model.alpha >= 0 || f.model.c >= 0 || f.model.beta >= 0 || f.model.spring_ratio >= 0 ||
                      !f.model.law.empty();
  configs.push_back({config_label(selected, custom ? "custom" : f.model.constants), selected});
  for (const auto& [kind, preset] : std::vector<std::pair<tissue::TissueModelKind, std::string>>{
           {tissue::TissueModelKind::MssCs, "recommended"},
           {tissue::TissueModelKind::MssCs, "thesis"},
           {tissue::TissueModelKind::MssCf, ""},
           {tissue::TissueModelKind::Mss, ""}}) {
    tissue::MassSpringOptions o;
    o.kind = kind;
    o.corrective = tissue::CorrectiveSpringConstants::preset(kind == tissue::TissueModelKind::MssCs ? preset : "thesis");
    o.cf_poisson_ratio = f.model.cf_poisson;
    const std::string label = config_label(o, preset);
    bool seen = false;
    for (const auto& c : configs) seen |= c.label == label;
    if (!seen) configs.push_back({label, o});
  }
  return configs;
}

/// Runs the experiment for each configuration and appends each model's errors and rows to
/// summary["models"]. The selected model (the first) must converge; a reference may stop early.
CubeResults run_cube_configs(const CubeFlags& f, const tissue::CubeExperimentOptions& base,
                             const std::vector<CubeConfig>& configs, nlohmann::json& summary) {
  CubeResults results;
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
  return results;
}

/// cube.csv (the selected model) and cube_all.csv (every model, with its index).
void write_cube_csvs(const std::filesystem::path& out, const CubeResults& results) {
  // *_reference: the uniaxial stress state of the model's own energy (continuum models; nan otherwise).
  const std::vector<std::string> header = {"weight_n", "top_pressure_analytic_pa", "top_pressure_pa",
                                           "displacement_ratio_analytic", "displacement_ratio", "volume_ratio",
                                           "displacement_ratio_reference", "volume_ratio_reference"};
  report::write_csv(out / "cube.csv", header, csv_rows(results.front().second));
  std::vector<std::vector<double>> all_rows;
  std::vector<std::string> h = header;
  h.insert(h.begin(), "model_index");
  for (size_t m = 0; m < results.size(); ++m)
    for (auto row : csv_rows(results[m].second)) {
      row.insert(row.begin(), static_cast<double>(m));
      all_rows.push_back(row);
    }
  report::write_csv(out / "cube_all.csv", h, all_rows);
}

/// The three panels of the thesis's Figs. 28–30: top pressure, displacement ratio and volume.
struct CubePlots {
  report::Plot pressure{"Top pressure (Fig. 28)", "box weight [N]", "pressure [kPa]", {}, {}, {}, {}, {}};
  report::Plot disp{"Displacement ratio (Fig. 29)", "box weight [N]", "displacement / edge", {}, {}, {}, {}, {}};
  report::Plot vol{"Volume (Fig. 30)", "box weight [N]", "volume [cm^3]", {}, {}, {}, {}, {}};
};

/// The analytic curves (W/A, W/(AE), the initial volume) and, where the selected continuum model
/// has one, the analytic uniaxial state of its own energy.
void add_analytic_series(CubePlots& plots, const CubeResults& results, double v0_cm3) {
  const auto& first = results.front().second;
  report::PlotSeries an_p{"analytic W/A", {}, {}, "#000000", true, false, 2};
  report::PlotSeries an_d{"analytic W/(AE)", {}, {}, "#000000", true, false, 2};
  report::PlotSeries an_v{"initial volume", {}, {}, "#000000", true, false, 2};
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
  plots.pressure.series.push_back(an_p);
  plots.disp.series.push_back(an_d);
  plots.vol.series.push_back(an_v);
  if (!ref_d.x.empty()) {
    plots.disp.series.push_back(ref_d);
    plots.vol.series.push_back(ref_v);
  }
}

/// cube.svg: the analytic curves, then each model's simulated curves.
void write_cube_svg(const std::filesystem::path& out, const CubeResults& results, double edge_mm) {
  CubePlots plots;
  const double v0_cm3 = std::pow(edge_mm / 10.0, 3);
  add_analytic_series(plots, results, v0_cm3);
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
    plots.pressure.series.push_back(sp);
    plots.disp.series.push_back(sd);
    plots.vol.series.push_back(sv);
  }
  report::write_svg_grid(out / "cube.svg", {plots.pressure, plots.disp, plots.vol}, 3);
}

/// summary.json (the selected model also under "selected") and the closing lines on the selected
/// model's errors.
void write_cube_summary(const CubeFlags& f, const std::filesystem::path& out, const tissue::CubeExperimentOptions& base,
                        const CubeResults& results, nlohmann::json& summary) {
  const auto& first = results.front().second;
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
}

void run_cube(const CubeFlags& f) {
  const std::filesystem::path out(f.out);
  ensure_directory(out);
  const tissue::CubeExperimentOptions base = cube_base_options(f);
  nlohmann::json summary;
  const CubeResults results = run_cube_configs(f, base, cube_configs(f), summary);
  write_cube_csvs(out, results);
  write_cube_svg(out, results, f.edge_mm);
  write_cube_summary(f, out, base, results, summary);
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
