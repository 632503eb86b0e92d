// `socketsmith validate cube` and `socketsmith validate design CASE`: socketsmith against
// CalculiX (an independent FE solver) on the same mesh — the thesis's FE checks (ch. 3.6, 5.5).
#include <chrono>
#include <cmath>
#include <filesystem>

#include "cli_common.h"
#include "socketsmith/core/atomic_file.h"
#include "socketsmith/core/errors.h"
#include "socketsmith/core/log.h"
#include "socketsmith/core/progress.h"
#include "socketsmith/fe/cube_validation.h"
#include "socketsmith/report/csv.h"
#include "socketsmith/report/svg_plot.h"

namespace socketsmith::cli {
namespace {

namespace fs = std::filesystem;

struct CcxFlags {
  std::string ccx = "ccx";
  int threads = 1;
  double time_limit_s = 3600;
};

void add_ccx_flags(CLI::App& cmd, CcxFlags& f) {
  cmd.add_option("--ccx", f.ccx, "CalculiX executable (default: ccx on the PATH; package calculix-ccx)");
  cmd.add_option("--ccx-threads", f.threads, "threads for ccx (default 1)")->check(CLI::Range(1, 64));
  cmd.add_option("--ccx-time-limit", f.time_limit_s, "wall-time limit of ccx [s] (default 3600)")->check(CLI::PositiveNumber);
}

fe::CcxOptions ccx_options(const CcxFlags& f) {
  fe::CcxOptions o;
  o.executable = f.ccx;
  o.threads = f.threads;
  o.time_limit_s = f.time_limit_s;
  o.progress = console_progress(2.0);
  return o;
}

struct CubeFlags {
  std::string out;
  bool json = false;
  int divisions = 4;
  double youngs_kpa = 50, poisson = 0.45, max_force = 8, edge_mm = 50;
  int increments = 8;
  std::string element = "c3d8";
  CcxFlags ccx;
};

void run_validate_cube(const CubeFlags& f) {
  const fs::path out(f.out);
  ensure_directory(out);
  fe::CubeFeOptions o;
  o.edge_m = f.edge_mm * 1e-3;
  o.divisions = f.divisions;
  o.youngs_modulus_pa = f.youngs_kpa * 1e3;
  o.poisson_ratio = f.poisson;
  o.max_force_n = f.max_force;
  o.increments = f.increments;
  o.element = fe::parse_element_type(f.element);
  o.ccx = ccx_options(f.ccx);
  const auto r = fe::run_cube_fe(o, out);
  std::vector<std::vector<double>> rows;
  for (size_t k = 0; k < r.force_n.size(); ++k)
    rows.push_back({r.force_n[k], r.fe_displacement_m[k] * 1e3, r.analytic_displacement_m[k] * 1e3,
                    r.fe_pressure_pa[k] / 1e3, r.analytic_pressure_pa[k] / 1e3});
  report::write_csv(out / "cube_fe.csv",
                    {"force_n", "fe_displacement_mm", "analytic_displacement_mm", "fe_pressure_kpa", "analytic_pressure_kpa"},
                    rows);
  const auto scaled = [](const std::vector<double>& v, double s) {
    std::vector<double> o2;
    for (double x : v) o2.push_back(x * s);
    return o2;
  };
  report::Plot pd;
  pd.title = "Cube: top displacement, CalculiX vs analytic";
  pd.x_label = "plate force [N]";
  pd.y_label = "displacement [mm]";
  pd.series = {{"CalculiX", r.force_n, scaled(r.fe_displacement_m, 1e3), "", false, true, 2},
               {"analytic F L / (A E)", r.force_n, scaled(r.analytic_displacement_m, 1e3), "", true, false, 2}};
  report::Plot pp = pd;
  pp.title = "Cube: top contact pressure, CalculiX vs analytic";
  pp.y_label = "pressure [kPa]";
  pp.series = {{"CalculiX (mean nodal CPRESS)", r.force_n, scaled(r.fe_pressure_pa, 1e-3), "", false, true, 2},
               {"analytic F / (A (1 + ν ε)²)", r.force_n, scaled(r.analytic_pressure_pa, 1e-3), "", true, false, 2}};
  report::write_svg_grid(out / "cube_fe.svg", {pd, pp}, 2);
  nlohmann::json j{{"nodes", r.nodes},
                   {"elements", r.elements},
                   {"element", fe::to_string(o.element)},
                   {"youngs_modulus_kpa", f.youngs_kpa},
                   {"poisson_ratio", f.poisson},
                   {"max_force_n", r.force_n.back()},
                   {"max_displacement_rel_error", r.max_displacement_rel_error},
                   {"max_pressure_rel_error", r.max_pressure_rel_error},
                   {"displacement", fe::to_json(r.displacement, 1e3, "_mm")},
                   {"pressure", fe::to_json(r.pressure, 1e-3, "_kpa")},
                   {"pressure_without_edges", fe::to_json(r.interior_pressure, 1e-3, "_kpa")},
                   {"ccx_wall_s", r.ccx.wall_s},
                   {"ccx_increments", r.ccx.increments},
                   {"deck", "cube.inp"},
                   {"outputs", {"cube.inp", "cube.frd", "cube.dat", "cube.log", "cube_fe.csv", "cube_fe.svg", "summary.json"}},
                   {"out", out.string()}};
  write_text_atomically(out / "summary.json", j.dump(2) + "\n");
  if (f.json) {
    print_json(j);
    return;
  }
  log::info("validate cube: {} nodes, {} elements ({}), ccx {:.1f} s", r.nodes, r.elements, fe::to_string(o.element),
            r.ccx.wall_s);
  log::info("validate cube: top displacement max error {:.2f} % of analytic; contact pressure max error {:.2f} %, "
            "nodal R {:.4f}, MAE {:.3f} kPa",
            100 * r.max_displacement_rel_error, 100 * r.max_pressure_rel_error, r.pressure.r, r.pressure.mae / 1e3);
  log::info("validate cube: outputs in {}", out.string());
}

}  // namespace

void register_validate(CLI::App& app) {
  auto* v = app.add_subcommand("validate", "compare socketsmith with CalculiX (ccx) on the same mesh");
  v->require_subcommand(1);

  auto cf = std::make_shared<CubeFlags>();
  auto* cube = v->add_subcommand("cube", "the thesis's cube in CalculiX against the analytic solution (checks the FE chain)");
  cube->add_option("--out", cf->out, "output folder (cube.inp, cube_fe.csv, cube_fe.svg, summary.json)")->required();
  cube->add_flag("--json", cf->json, "print the summary as JSON on stdout");
  cube->add_option("--divisions", cf->divisions, "elements per edge (default 4)")->check(CLI::Range(1, 40));
  cube->add_option("--youngs-kpa", cf->youngs_kpa, "Young's modulus [kPa] (default 50)");
  cube->add_option("--poisson", cf->poisson, "Poisson ratio (default 0.45)");
  cube->add_option("--max-force", cf->max_force, "plate force at the end [N] (default 8: 6.4 % strain)");
  cube->add_option("--increments", cf->increments, "equal load increments (default 8)")->check(CLI::Range(1, 100));
  cube->add_option("--edge-mm", cf->edge_mm, "cube edge [mm] (default 50)");
  cube->add_option("--element", cf->element, "c3d8 | c3d8i | c3d8r (default c3d8)");
  add_ccx_flags(*cube, cf->ccx);
  cube->callback([cf] { run_validate_cube(*cf); });
}

}  // namespace socketsmith::cli
