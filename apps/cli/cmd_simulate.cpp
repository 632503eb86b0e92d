// `socketsmith simulate cube`: the thesis's cube experiment (Figs. 28–30); the study and its files
// are pipeline::run_cube_study's.
#include <cmath>
#include <filesystem>

#include "cli_common.h"
#include "socketsmith/core/log.h"
#include "socketsmith/pipeline/cube_study.h"

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

/// The name of the selected model's constants in its label: the preset's, or "custom" when a
/// constant or the law is given on its own.
std::string constants_label(const ModelFlags& m) {
  const bool custom = m.golec_a >= 0 || m.alpha >= 0 || m.c >= 0 || m.beta >= 0 || m.spring_ratio >= 0 || !m.law.empty();
  return custom ? "custom" : m.constants;
}

/// The study's outputs, then the selected model's errors in one or two lines (or its summary as JSON).
void run_cube(const CubeFlags& f) {
  pipeline::CubeStudyRequest request;
  request.experiment = cube_base_options(f);
  request.models = pipeline::cube_study_models(make_model_options(f.model), constants_label(f.model));
  request.progress = console_progress(1.0);
  const std::filesystem::path out(f.out);
  const pipeline::CubeStudy study = pipeline::run_cube_study(request, out);
  const auto& selected = study.runs.front();
  const auto err = tissue::cube_errors(selected.result);
  log::info("{}: max displacement error {:.2f}% (to 60% strain), max volume error {:.2f}% (to 40% strain)",
            selected.label, 100 * err.max_displacement_error, 100 * err.max_volume_error);
  if (std::isfinite(err.max_displacement_error_reference))
    log::info("{}: against the analytic uniaxial state of its own energy (every weight solved): max displacement error "
              "{:.3g}%, max volume error {:.3g}% of V0",
              selected.label, 100 * err.max_displacement_error_reference, 100 * err.max_volume_error_reference);
  log::info("wrote {}", (out / "cube.csv").string());
  if (f.json) print_json(study.summary["selected"]);
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
