#include "socketsmith/pipeline/cube_study.h"

#include <cmath>
#include <utility>

#include "socketsmith/core/atomic_file.h"
#include "socketsmith/core/errors.h"
#include "socketsmith/core/log.h"
#include "socketsmith/core/units.h"
#include "socketsmith/report/csv.h"
#include "socketsmith/report/svg_plot.h"
#include "socketsmith/tissue/tissue_model_json.h"

namespace socketsmith::pipeline {
namespace {

namespace fs = std::filesystem;

nlohmann::json finite_or_null(double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(); }

/// A cube row's number columns as cube.csv and summary.json's rows name them. cube.csv holds the
/// first kCsvColumns; *_reference (the uniaxial state of the model's own energy) and the stiffness
/// eigenvalue are NaN where there is none: null in the JSON, nan in the CSV.
struct RowColumn {
  const char* name;
  double tissue::CubeRow::*value;
  bool is_null_when_not_finite;
};
constexpr RowColumn kRowColumns[] = {
    {"weight_n", &tissue::CubeRow::weight_n, false},
    {"top_pressure_analytic_pa", &tissue::CubeRow::top_pressure_analytic_pa, false},
    {"top_pressure_pa", &tissue::CubeRow::top_pressure_pa, false},
    {"displacement_ratio_analytic", &tissue::CubeRow::displacement_ratio_analytic, false},
    {"displacement_ratio", &tissue::CubeRow::displacement_ratio, false},
    {"volume_ratio", &tissue::CubeRow::volume_ratio, false},
    {"displacement_ratio_reference", &tissue::CubeRow::displacement_ratio_reference, true},
    {"volume_ratio_reference", &tissue::CubeRow::volume_ratio_reference, true},
    {"top_pressure_true_pa", &tissue::CubeRow::top_pressure_true_pa, false},
    {"nodal_pressure_spread", &tissue::CubeRow::nodal_pressure_spread, false},
    {"lateral_stretch", &tissue::CubeRow::lateral_stretch, false},
    {"min_stiffness_eigenvalue_n_per_m", &tissue::CubeRow::min_stiffness_eigenvalue, true}};
constexpr size_t kCsvColumns = 8;

nlohmann::json rows_json(const tissue::CubeExperimentResult& r) {
  nlohmann::json rows = nlohmann::json::array();
  for (const auto& row : r.rows) {
    nlohmann::json j{{"newton_iterations", row.newton_iterations}};
    for (const RowColumn& c : kRowColumns)
      j[c.name] = c.is_null_when_not_finite ? finite_or_null(row.*c.value) : nlohmann::json(row.*c.value);
    rows.push_back(j);
  }
  return rows;
}

/// A model's entry in summary["models"]: its options, whether it converged, its errors and rows.
nlohmann::json model_json(const CubeStudyRun& run, const tissue::MassSpringOptions& options,
                          const tissue::TissueMaterial& material) {
  const tissue::CubeExperimentResult& r = run.result;
  const auto err = tissue::cube_errors(r);
  return {{"label", run.label},
          {"options", tissue::tissue_model_json(options, material)},
          {"converged", r.converged},
          {"message", r.message},
          {"max_displacement_error_to_60pct", err.max_displacement_error},
          {"max_volume_error_to_40pct", err.max_volume_error},
          {"unstable_before_60pct", err.unstable},
          {"max_displacement_error_vs_own_energy", finite_or_null(err.max_displacement_error_reference)},
          {"max_volume_error_vs_own_energy", finite_or_null(err.max_volume_error_reference)},
          {"wall_s", r.wall_s},
          {"rows", rows_json(r)}};
}

std::vector<std::vector<double>> csv_rows(const tissue::CubeExperimentResult& r) {
  std::vector<std::vector<double>> rows;
  for (const auto& row : r.rows) {
    std::vector<double>& values = rows.emplace_back();
    for (size_t c = 0; c < kCsvColumns; ++c) values.push_back(row.*kRowColumns[c].value);
  }
  return rows;
}

/// cube.csv (the selected model) and cube_all.csv (every model, with its index).
void write_cube_csvs(const fs::path& out, const std::vector<CubeStudyRun>& runs) {
  std::vector<std::string> header;
  for (size_t c = 0; c < kCsvColumns; ++c) header.emplace_back(kRowColumns[c].name);
  report::write_csv(out / "cube.csv", header, csv_rows(runs.front().result));
  std::vector<std::vector<double>> all_rows;
  std::vector<std::string> h = header;
  h.insert(h.begin(), "model_index");
  for (size_t m = 0; m < runs.size(); ++m)
    for (auto row : csv_rows(runs[m].result)) {
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

/// A point of a curve against the box weight: (the row's weight, @p value).
void add_point(report::PlotSeries& series, const tissue::CubeRow& row, double value) {
  series.x.push_back(row.weight_n);
  series.y.push_back(value);
}

/// The analytic curves (W/A, W/(AE), the initial volume) and, where the selected continuum model
/// has one, the analytic uniaxial state of its own energy.
void add_analytic_series(CubePlots& plots, const std::vector<CubeStudyRun>& runs, double v0_cm3) {
  const auto& first = runs.front().result;
  report::PlotSeries an_p{"analytic W/A", {}, {}, "#000000", true, false, 2};
  report::PlotSeries an_d{"analytic W/(AE)", {}, {}, "#000000", true, false, 2};
  report::PlotSeries an_v{"initial volume", {}, {}, "#000000", true, false, 2};
  report::PlotSeries ref_d{runs.front().label + ", analytic", {}, {}, "#555555", true, false, 1}, ref_v = ref_d;
  for (const auto& row : first.rows) {
    add_point(an_p, row, row.top_pressure_analytic_pa / 1e3);
    add_point(an_d, row, row.displacement_ratio_analytic);
    add_point(an_v, row, v0_cm3);
    if (!std::isfinite(row.displacement_ratio_reference)) continue;
    add_point(ref_d, row, row.displacement_ratio_reference);
    add_point(ref_v, row, row.volume_ratio_reference * v0_cm3);
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
void write_cube_svg(const fs::path& out, const std::vector<CubeStudyRun>& runs, double edge_mm) {
  CubePlots plots;
  const double v0_cm3 = std::pow(edge_mm / 10.0, 3);
  add_analytic_series(plots, runs, v0_cm3);
  for (const auto& run : runs) {
    report::PlotSeries sp{run.label, {}, {}, "", false, true, 2}, sd = sp, sv = sp;
    for (const auto& row : run.result.rows) {
      add_point(sp, row, row.top_pressure_pa / 1e3);
      add_point(sd, row, row.displacement_ratio);
      add_point(sv, row, row.volume_ratio * v0_cm3);
    }
    plots.pressure.series.push_back(sp);
    plots.disp.series.push_back(sd);
    plots.vol.series.push_back(sv);
  }
  report::write_svg_grid(out / "cube.svg", {plots.pressure, plots.disp, plots.vol}, 3);
}

}  // namespace

std::string cube_model_label(const tissue::MassSpringOptions& o, const std::string& constants) {
  if (o.kind != tissue::TissueModelKind::MssCs) return tissue::to_string(o.kind);
  return "mss-cs (" + constants + ")";
}

std::vector<CubeStudyModel> cube_study_models(const tissue::MassSpringOptions& selected, const std::string& constants) {
  std::vector<CubeStudyModel> models{{cube_model_label(selected, constants), selected}};
  for (const auto& [kind, preset] : std::vector<std::pair<tissue::TissueModelKind, std::string>>{
           {tissue::TissueModelKind::MssCs, "recommended"},
           {tissue::TissueModelKind::MssCs, "thesis"},
           {tissue::TissueModelKind::MssCf, ""},
           {tissue::TissueModelKind::Mss, ""}}) {
    tissue::MassSpringOptions o;
    o.kind = kind;
    o.corrective = tissue::CorrectiveSpringConstants::preset(kind == tissue::TissueModelKind::MssCs ? preset : "thesis");
    o.cf_poisson_ratio = selected.cf_poisson_ratio;
    const std::string label = cube_model_label(o, preset);
    bool seen = false;
    for (const auto& m : models) seen |= m.label == label;
    if (!seen) models.push_back({label, o});
  }
  return models;
}

CubeStudy run_cube_study(const CubeStudyRequest& request, const fs::path& out) {
  require(!request.models.empty(), "run_cube_study: no model to run (give the selected model first)");
  ensure_directory(out);
  const tissue::CubeExperimentOptions& base = request.experiment;
  CubeStudy study;
  study.summary["models"] = nlohmann::json::array();
  for (size_t i = 0; i < request.models.size(); ++i) {
    const CubeStudyModel& model = request.models[i];
    tissue::CubeExperimentOptions o = base;
    o.model = model.options;
    log::info("cube experiment: {} ({}^3 elements, {} weights up to {} N)", model.label, base.divisions,
              base.num_weights, base.max_weight_n);
    CubeStudyRun run{model.label, tissue::run_cube_experiment(o, request.progress)};
    if (i == 0 && !run.result.converged)
      fail<SolverError>("simulate cube: {} (try --divisions 4 or a smaller --max-weight)", run.result.message);
    if (!run.result.converged) log::warn("simulate cube: reference {} stopped early: {}", model.label, run.result.message);
    study.summary["models"].push_back(model_json(run, model.options, base.material));
    study.runs.push_back(std::move(run));
  }
  write_cube_csvs(out, study.runs);
  write_cube_svg(out, study.runs, base.edge_m / units::mm);
  nlohmann::json& summary = study.summary;
  const auto& first = study.runs.front().result;
  summary["command"] = "socketsmith simulate cube";
  summary["edge_m"] = base.edge_m;
  summary["divisions"] = base.divisions;
  summary["nodes"] = first.num_nodes;
  summary["elements"] = first.num_elements;
  summary["selected"] = summary["models"][0];
  summary["outputs"] = {(out / "cube.csv").string(), (out / "cube_all.csv").string(), (out / "cube.svg").string(),
                        (out / "summary.json").string()};
  write_text_atomically(out / "summary.json", summary.dump(2) + "\n");
  return study;
}

}  // namespace socketsmith::pipeline
