#include "socketsmith/calculix/cube_validation.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <vector>

#include "socketsmith/core/atomic_file.h"
#include "socketsmith/core/errors.h"
#include "socketsmith/calculix/dat_reader.h"
#include "socketsmith/calculix/frd_reader.h"
#include "socketsmith/report/csv.h"
#include "socketsmith/report/plot_raster.h"
#include "socketsmith/report/svg_plot.h"
#include "socketsmith/volume/box_mesher.h"

namespace socketsmith::calculix {

namespace {

/// The cube's top-face nodes, and which of them lie off the face's edges (indices into nodes).
struct CubeTop {
  std::vector<int> nodes;
  std::vector<int> interior;
};

/// The rollers of a cube of @p n divisions into @p spec: z fixed on the base, x on the face x = 0,
/// y on y = 0, so the cube widens freely under the plate. Returns the top face's nodes.
CubeTop support_cube(int n, DeckSpec& spec) {
  const std::array<int, 3> dv{n, n, n};
  CubeTop top;
  for (int k = 0; k <= n; ++k)
    for (int j = 0; j <= n; ++j)
      for (int i = 0; i <= n; ++i) {
        const int v = volume::box_node_index(dv, i, j, k);
        if (k == 0) spec.fixed_components.push_back({v, 2});
        if (i == 0) spec.fixed_components.push_back({v, 0});
        if (j == 0) spec.fixed_components.push_back({v, 1});
        if (k == n) {
          top.nodes.push_back(v);
          if (i > 0 && i < n && j > 0 && j < n) top.interior.push_back(static_cast<int>(top.nodes.size()) - 1);
        }
      }
  return top;
}

/// Top faces (local face 1 = 4-5-6-7, the +z face) of the top layer of a cube of @p n divisions.
std::vector<std::array<int, 4>> top_face_quads(int n) {
  const std::array<int, 3> dv{n, n, n};
  std::vector<std::array<int, 4>> top_quads;
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i)
      top_quads.push_back({volume::box_node_index(dv, i, j, n), volume::box_node_index(dv, i + 1, j, n),
                           volume::box_node_index(dv, i + 1, j + 1, n), volume::box_node_index(dv, i, j + 1, n)});
  return top_quads;
}

/// The plate: a square larger than the top (so the edges stay covered as the cube widens).
RigidShell make_plate(double edge_m) {
  const double L = edge_m, m = 0.25 * L;
  const std::vector<Vec3> pts{{-m, -m, L}, {L + m, -m, L}, {L + m, L + m, L}, {-m, L + m, L}};
  const std::vector<Vec3> up(4, Vec3::UnitZ());
  return extrude_shell(pts, up, {{0, 1, 2, 3}}, 0.1 * L);
}

/// The plate's travel and the step's increments: far enough for the largest force on the cube's
/// analytic stiffness plus the contact penalty's, in equal increments, geometry linear.
void set_plate_steps(const CubeFeOptions& o, DeckSpec& spec) {
  const double L = o.edge_m, A = L * L, E = o.youngs_modulus_pa;
  spec.contact.penalty_pa_per_m = o.penalty_pa_per_m;
  spec.contact.friction = 0;
  spec.steps.is_nonlinear_geometry = false;
  const double delta_max = o.max_force_n * L / (A * E) + o.max_force_n / A / o.penalty_pa_per_m;
  spec.steps.donning_travel_m = Vec3(0, 0, -delta_max);
  spec.steps.initial_increment = spec.steps.max_increment = 1.0 / o.increments;
  spec.steps.min_increment = std::min(1e-5, spec.steps.initial_increment);
}

/// Every top node's contact pressure in every increment, FE and analytic, and the indices of the
/// interior nodes' values.
struct TopPressures {
  std::vector<double> fe_pa, analytic_pa;
  std::vector<int> interior;
};

/// ccx's increments into @p res: per CONTACT block with its plate force (the .dat's REF forces at
/// the same time) and its displacements, the force, the mean top pressure and displacement, and the
/// analytic ones. Returns the nodal pressures of all increments.
TopPressures read_cube_increments(const CubeFeOptions& o, const CubeTop& top, int num_nodes, CubeFeResult& res) {
  const double L = o.edge_m, A = L * L, E = o.youngs_modulus_pa;
  const auto frd = read_frd(res.ccx.frd);
  const auto dat = read_dat(res.ccx.dat);
  std::vector<const DatBlock*> forces;
  for (const auto& b : dat)
    if (b.title.starts_with("forces") && b.set == "REF" && !b.rows.empty()) forces.push_back(&b);
  TopPressures nodal;
  for (const auto& blk : frd.blocks) {
    if (blk.name != "CONTACT") continue;
    const DatBlock* fb = nullptr;
    for (const auto* b : forces)
      if (std::abs(b->time - blk.time) < 1e-6) fb = b;
    const FrdBlock* disp = nullptr;
    for (const auto& d : frd.blocks)
      if (d.name == "DISP" && d.step == blk.step && d.increment == blk.increment) disp = &d;
    if (!fb || !disp || fb->rows[0].size() < 4) continue;
    const double F = std::abs(fb->rows[0][3]);
    const auto cp = blk.dense("CPRESS", num_nodes);
    const auto uz = disp->dense("D3", num_nodes);
    double p_mean = 0, u_mean = 0;
    for (size_t k = 0; k < top.nodes.size(); ++k) {
      const int v = top.nodes[k];
      p_mean += cp[v];
      u_mean += -uz[v];
      for (int t : top.interior)
        if (t == static_cast<int>(k)) nodal.interior.push_back(static_cast<int>(nodal.fe_pa.size()));
      nodal.fe_pa.push_back(cp[v]);
      nodal.analytic_pa.push_back(F / (A * std::pow(1 + o.poisson_ratio * F / (A * E), 2)));
    }
    res.force_n.push_back(F);
    res.fe_pressure_pa.push_back(p_mean / top.nodes.size());
    res.analytic_pressure_pa.push_back(F / (A * std::pow(1 + o.poisson_ratio * F / (A * E), 2)));
    res.fe_displacement_m.push_back(u_mean / top.nodes.size());
    res.analytic_displacement_m.push_back(F * L / (A * E));
  }
  return nodal;
}

/// FE against analytic in @p res: the error statistics and the largest relative errors.
void compare_with_analytic(const TopPressures& nodal, CubeFeResult& res) {
  res.displacement = report::compare_fields(res.fe_displacement_m, res.analytic_displacement_m);
  res.pressure = report::compare_fields(nodal.fe_pa, nodal.analytic_pa);
  res.interior_pressure = report::compare_fields(nodal.fe_pa, nodal.analytic_pa, nodal.interior);
  for (size_t k = 0; k < res.force_n.size(); ++k) {
    res.max_displacement_rel_error =
        std::max(res.max_displacement_rel_error,
                 std::abs(res.fe_displacement_m[k] - res.analytic_displacement_m[k]) / res.analytic_displacement_m[k]);
    res.max_pressure_rel_error =
        std::max(res.max_pressure_rel_error,
                 std::abs(res.fe_pressure_pa[k] - res.analytic_pressure_pa[k]) / res.analytic_pressure_pa[k]);
  }
}

}  // namespace

CubeFeResult run_cube_fe(const CubeFeOptions& o, const std::filesystem::path& dir) {
  require(o.edge_m > 0 && std::isfinite(o.edge_m), "run_cube_fe: edge {} m (expected > 0)", o.edge_m);
  require(o.divisions >= 1 && o.divisions <= 60, "run_cube_fe: divisions {} (expected 1..60)", o.divisions);
  require(o.max_force_n > 0, "run_cube_fe: max force {} N (expected > 0)", o.max_force_n);
  require(o.increments >= 1 && o.increments <= 100, "run_cube_fe: increments {} (expected 1..100)", o.increments);
  require(o.youngs_modulus_pa > 0, "run_cube_fe: Young's modulus {} Pa (expected > 0)", o.youngs_modulus_pa);
  find_ccx(o.ccx.executable);
  const int n = o.divisions;
  volume::BoxMeshOptions bo;
  bo.size = Vec3::Constant(o.edge_m);
  bo.divisions = {n, n, n};
  const volume::HexMesh cube = volume::mesh_box(bo);

  DeckSpec spec;
  spec.title = "socketsmith validate cube: rigid plate on the thesis's cube";
  spec.stump = &cube;
  spec.material.youngs_modulus_pa = o.youngs_modulus_pa;
  spec.material.poisson_ratio = o.poisson_ratio;
  spec.element = o.element;
  const CubeTop top = support_cube(n, spec);
  spec.skin_faces = faces_of_quads(cube, top_face_quads(n));
  const RigidShell plate = make_plate(o.edge_m);
  spec.socket = &plate;
  set_plate_steps(o, spec);

  ensure_directory(dir);
  CubeFeResult res;
  res.nodes = cube.num_nodes();
  res.elements = cube.num_hexahedra();
  res.deck = dir / "cube.inp";
  write_text_atomically(res.deck, write_deck(spec));
  CcxOptions co = o.ccx;
  co.num_steps = 1;
  res.ccx = run_ccx(dir, "cube", co);
  if (!res.ccx.converged) fail<SolverError>("validate cube: {}", res.ccx.message);

  const TopPressures nodal = read_cube_increments(o, top, cube.num_nodes(), res);
  if (res.force_n.empty())
    fail<SolverError>("validate cube: ccx finished but its results hold no contact increment ({}, {}): read the log {}",
                      res.ccx.frd.string(), res.ccx.dat.string(), res.ccx.log.string());
  compare_with_analytic(nodal, res);
  return res;
}

namespace {

std::vector<double> scaled(const std::vector<double>& v, double s) {
  std::vector<double> out;
  for (double x : v) out.push_back(x * s);
  return out;
}

/// cube_fe.csv, cube_fe.svg and cube_fe.png: CalculiX against the analytic solution.
void write_cube_fe_files(const CubeFeResult& r, const std::filesystem::path& out) {
  std::vector<std::vector<double>> rows;
  for (size_t k = 0; k < r.force_n.size(); ++k)
    rows.push_back({r.force_n[k], r.fe_displacement_m[k] * 1e3, r.analytic_displacement_m[k] * 1e3,
                    r.fe_pressure_pa[k] / 1e3, r.analytic_pressure_pa[k] / 1e3});
  report::write_csv(out / "cube_fe.csv",
                    {"force_n", "fe_displacement_mm", "analytic_displacement_mm", "fe_pressure_kpa", "analytic_pressure_kpa"},
                    rows);
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
  report::write_plot_grid_png(out / "cube_fe.png", {pd, pp}, 2);
}

}  // namespace

CubeFeValidation validate_cube_fe(const CubeFeOptions& o, const std::filesystem::path& out) {
  ensure_directory(out);
  CubeFeValidation v;
  v.result = run_cube_fe(o, out);
  const CubeFeResult& r = v.result;
  write_cube_fe_files(r, out);
  v.summary = {{"nodes", r.nodes},
               {"elements", r.elements},
               {"element", to_string(o.element)},
               {"youngs_modulus_kpa", o.youngs_modulus_pa / 1e3},
               {"poisson_ratio", o.poisson_ratio},
               {"max_force_n", r.force_n.back()},
               {"max_displacement_rel_error", r.max_displacement_rel_error},
               {"max_pressure_rel_error", r.max_pressure_rel_error},
               {"displacement", report::to_json(r.displacement, 1e3, "_mm")},
               {"pressure", report::to_json(r.pressure, 1e-3, "_kpa")},
               {"pressure_without_edges", report::to_json(r.interior_pressure, 1e-3, "_kpa")},
               {"ccx_wall_s", r.ccx.wall_s},
               {"ccx_increments", r.ccx.increments},
               {"deck", "cube.inp"},
               {"outputs", {"cube.inp", "cube.frd", "cube.dat", "cube.log", "cube_fe.csv", "cube_fe.svg", "cube_fe.png", "summary.json"}},
               {"out", out.string()}};
  write_text_atomically(out / "summary.json", v.summary.dump(2) + "\n");
  return v;
}

}  // namespace socketsmith::calculix
