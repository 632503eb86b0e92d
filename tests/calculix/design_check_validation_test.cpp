// CalculiX on a designed socket (the embedded sample at ~3k nodes; ccx runs ~2 min per check on
// 2 cores): labelled `validation`. Both checks of docs/validation_fe.md, with the bars they meet.
#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <string>

#include <gtest/gtest.h>

#include "socketsmith/calculix/text_file.h"
#include "socketsmith/core/units.h"
#include "socketsmith/pipeline/closed_loop.h"
#include "socketsmith/pipeline/design_validation.h"
#include "socketsmith/pipeline/validation_inputs.h"
#include "socketsmith/report/delivery_bar.h"
#include "socketsmith/report/field_comparison.h"

namespace socketsmith::calculix {
namespace {

namespace fs = std::filesystem;

/// The demo case with the seven constraints only (design.follow_template false): the design these
/// checks' bars were measured on. The template-following demo design (the default since issue 22)
/// is more peaked at the patellar tendon; its figures against CalculiX are in docs/VALIDATION.md
/// ("Designs that mean their template"): CalculiX's load step at ν 0.25 does not converge on it.
design::CaseFile plain_demo_case(int nodes) {
  design::CaseFile c = pipeline::demo_case(nodes);
  c.follow_template = false;
  // The thesis's lattice, linearised: what these bars were measured on (the default model is
  // neo-Hookean since its end-to-end check, docs/design.md).
  c.model = "mss-cs";
  c.solve_mode = design::DesignSolveMode::Linear;
  c.closed_loop = false;  // the open-loop design is what these bars measure
  return c;
}

struct Designed {
  pipeline::DesignArtifacts art;
  DesignedStump stump;
  Designed() {
    const fs::path out = fs::path(SOCKETSMITH_BINARY_DIR) / "fe_test_runs" / "design_3k";
    pipeline::run_design(plain_demo_case(3000), out / "design", true, {}, &art);
    stump = pipeline::designed_stump(art);
  }
};

Designed& designed() {
  static Designed d;
  return d;
}

fs::path run_dir(const std::string& name) {
  const fs::path d = fs::path(SOCKETSMITH_BINARY_DIR) / "fe_test_runs" / name;
  fs::remove_all(d);
  return d;
}

TEST(DesignCheckValidation, designed_loads_in_calculix_balance_and_deform_the_stump_alike) {
  auto& d = designed();
  DesignCheckOptions o;
  o.mode = DesignCheckMode::Load;
  o.material.youngs_modulus_pa = 100e3;
  o.material.poisson_ratio = 0.25;  // the MSS lattice's own Poisson ratio
  const auto r = check_design(d.stump, o, run_dir("design_3k_load"));
  ASSERT_TRUE(r.converged) << r.message;
  // The bones carry the patient's load: half the body weight less the share friction takes on the
  // skin (the radar's S — load mode applies the pressures alone). Both come from the case and the
  // design's radar, not from the arrays the deck was written from: comparing the reaction with the
  // sum of those arrays (kept below) holds by equilibrium whatever they contain, so it could not
  // catch a deck that applies the wrong loads (units, sign, nodes left out).
  const double half_weight = 0.5 * d.art.setup->case_file.patient.body_mass_kg * units::kGravity;
  const double pressure_share = half_weight - d.art.result.state.radar.stability_n;
  ASSERT_GT(pressure_share, 0.05 * half_weight);
  std::printf("[ info ] CalculiX bone reaction %.1f N; M g / 2 - S = %.1f - %.1f = %.1f N\n", r.fe_force_n, half_weight,
              d.art.result.state.radar.stability_n, pressure_share);
  EXPECT_NEAR(r.fe_force_n, pressure_share, 0.02 * half_weight);
  // And every designed load reached the deck (equilibrium of what was applied).
  EXPECT_NEAR(r.fe_force_n, r.designed_force_n, 0.01 * r.designed_force_n);
  // Shape: FE and socketsmith displacements correlate on the socket.
  EXPECT_GT(r.all.r, 0.8);
}

TEST(DesignCheckValidation, calculix_contact_pressure_in_the_designed_socket) {
  auto& d = designed();
  DesignCheckOptions o;
  o.material.youngs_modulus_pa = 100e3;
  o.material.poisson_ratio = 0.25;
  const auto r = check_design(d.stump, o, run_dir("design_3k_contact"));
  ASSERT_TRUE(r.converged) << r.message;
  EXPECT_GT(r.max_penetration_m, 0);
  EXPECT_LT(r.max_penetration_m, 0.5e-3);
  ASSERT_EQ(r.paths.size(), 3u);
  EXPECT_GT(r.paths[0].stats.count, 10);
  // The MSS-CS design (the thesis's model) against CalculiX's continuum, nodal-force pressure
  // (measured 2026-11-25 with −n·σ·n: every socket node R 0.84, MAE 2.0 kPa; front line R 0.73;
  // with nodal CPRESS R 0.48, MAE 2.8 kPa).
  ASSERT_EQ(r.fe_pressure, FePressure::NodalForce);
  std::printf("[ info ] MSS-CS design vs CalculiX: every node MAE %.2f kPa, R %.3f; front line R %.3f "
              "(-n.sigma.n MAE %.2f kPa, R %.3f; CPRESS R %.3f)\n",
              r.all.mae / 1e3, r.all.r, r.paths[0].stats.r, r.all_stress.mae / 1e3, r.all_stress.r, r.all_cpress.r);
  // Measured 2026-11-25: nodal force MAE 2.47 kPa, R 0.81; −n·σ·n 2.00 kPa, R 0.84. The lattice and
  // the continuum differ, and the nodal force (a difference of neighbouring displacements) shows it.
  EXPECT_GT(r.all.r, 0.75);
  EXPECT_LT(r.all.mae, 3.0e3);
  EXPECT_GT(r.all_stress.r, 0.8);
  EXPECT_LT(r.all_stress.mae, 2.5e3);
  EXPECT_GT(r.paths[0].stats.r, 0.6);  // front line
  EXPECT_GT(r.all.r, r.all_cpress.r);
  // Where the lattice and the continuum part at the sharpest features, 3 nodes stand out of their
  // neighbours (measured 2026-12-06, with 5 % or 2.5 % increments alike): not CalculiX's path, no rerun.
  EXPECT_LT(r.fe_alternating_nodes, o.alternation_rerun_nodes);
  EXPECT_EQ(r.ccx_runs, 1);
  EXPECT_EQ(r.ccx_total_wall_s, r.ccx.wall_s);
}

/// The embedded sample designed with the fe tissue model (socketsmith's St Venant–Kirchhoff
/// hexahedra, CalculiX's C3D8 with the same E and ν 0.45).
struct DesignedFe {
  pipeline::DesignArtifacts art;
  DesignedStump stump;
  design::CaseFile c = plain_demo_case(3000);
  DesignedFe() {
    c.model = "fe";
    const fs::path out = fs::path(SOCKETSMITH_BINARY_DIR) / "fe_test_runs" / "design_fe_3k";
    pipeline::run_design(c, out / "design", true, {}, &art);
    stump = pipeline::designed_stump(art);
  }
};

TEST(DesignCheckValidation, an_fe_model_design_meets_the_thesis_bar_on_every_path) {
  // The thesis's ch. 5 check (its Abaqus: MAE 2.5 ± 2.75 kPa, R 0.90–0.95 on the paths), with the
  // tissue model that is CalculiX's own element: the designed socket, fitted in CalculiX (NLGEOM,
  // penalty contact, μ 0.5), gives back the designed pressures. Measured 2026-11-25 on OpenLimb's four
  // cases: every path R 0.97–1.00, MAE 0.40–0.91 kPa. And the designed loads alone, in a
  // small-strain CalculiX step, deform CalculiX's stump as they deformed socketsmith's: same
  // element, same material, same linear problem (measured: R 1.0000, 0.03 mm at most; under NLGEOM
  // the St Venant–Kirchhoff stump yields more, mean 0.56 vs 0.44 mm, R 0.97).
  static DesignedFe d;
  DesignCheckOptions o;
  o.material.youngs_modulus_pa = d.c.youngs_modulus_pa;
  o.material.poisson_ratio = 0.45;
  const auto r = check_design(d.stump, o, run_dir("design_fe_3k_contact"));
  ASSERT_TRUE(r.converged) << r.message;
  ASSERT_EQ(r.fe_pressure, FePressure::NodalForce);
  std::printf("[ info ] fe-model design vs CalculiX: every node MAE %.2f kPa, R %.3f; paths R %.3f / %.3f / %.3f "
              "(-n.sigma.n R %.3f, CPRESS R %.3f)\n",
              r.all.mae / 1e3, r.all.r, r.paths[0].stats.r, r.paths[1].stats.r, r.paths[2].stats.r, r.all_stress.r,
              r.all_cpress.r);
  EXPECT_GT(r.all.r, 0.95);
  EXPECT_LT(r.all.mae, 1.5e3);
  ASSERT_EQ(r.paths.size(), 3u);
  for (const auto& p : r.paths) {
    EXPECT_GT(p.stats.count, 10) << p.name;
    EXPECT_GT(p.stats.r, 0.90) << p.name;
    EXPECT_LT(p.stats.mae, 1.5e3) << p.name;
  }
  EXPECT_GT(r.all.r, r.all_stress.r);  // the nodal force needs no stress extrapolation

  o.mode = DesignCheckMode::Load;
  o.nonlinear_geometry = false;
  const auto l = check_design(d.stump, o, run_dir("design_fe_3k_load"));
  ASSERT_TRUE(l.converged) << l.message;
  EXPECT_NEAR(l.fe_force_n, l.designed_force_n, 0.01 * l.designed_force_n);
  std::printf("[ info ] fe-model design, loads alone, small strain: displacement MAE %.4f mm of mean %.3f mm, R %.5f\n",
              l.all.mae * 1e3, l.all.mean_b * 1e3, l.all.r);
  EXPECT_GT(l.all.r, 0.999);
  EXPECT_LT(l.all.mae, 0.01 * l.all.mean_b);
}

TEST(DesignCheckValidation, a_neo_hookean_nonlinear_design_deforms_calculixs_neo_hooke_stump_alike) {
  // The neo-Hookean tissue model, nonlinear design solve (follower pressure), and its CalculiX twin
  // (*HYPERELASTIC, NEO HOOKE, NLGEOM, from fe_material): the designed loads, applied in CalculiX as
  // nodal forces, must deform CalculiX's stump as they deformed socketsmith's (same element, same
  // energy, same equilibrium). Measured at 3k nodes: mean |difference| 3.7e-7 mm on 0.78 mm, R 1.
  design::CaseFile c = pipeline::demo_case(2000);
  c.model = "neo-hookean";
  c.solve_mode = design::DesignSolveMode::Nonlinear;
  c.closed_loop = false;  // the designed loads are what CalculiX gets
  pipeline::DesignArtifacts art;
  pipeline::run_design(c, run_dir("design_nh_2k") / "design", true, {}, &art);
  ASSERT_FALSE(art.result.state.linearised);
  const DesignedStump stump = pipeline::designed_stump(art);
  DesignCheckOptions o;
  o.mode = DesignCheckMode::Load;
  o.material = pipeline::fe_material(c);
  ASSERT_TRUE(o.material.is_neo_hookean);
  ASSERT_TRUE(o.nonlinear_geometry);
  const auto r = check_design(stump, o, run_dir("design_nh_2k_load"));
  ASSERT_TRUE(r.converged) << r.message;
  std::printf("[ info ] neo-Hookean design, loads alone, NLGEOM: displacement MAE %.2e mm of mean %.3f mm, R %.8f\n",
              r.all.mae * 1e3, r.all.mean_b * 1e3, r.all.r);
  EXPECT_NEAR(r.fe_force_n, r.designed_force_n, 0.001 * r.designed_force_n);
  EXPECT_GT(r.all.r, 0.9999);
  EXPECT_LT(r.all.mae, 1e-4 * r.all.mean_b);
}

// F-bar (tissue.element fbar) against CalculiX's incompatible-mode hexahedron, which does not lock
// either, at ν 0.49 where the fully integrated C3D8 does (docs/tissue.md, "Locking"): the designed
// loads applied in CalculiX (C3D8I, NLGEOM) deform its stump as they deformed socketsmith's F-bar
// stump, while socketsmith's C3D8 stump under its own design loads moves clearly less than C3D8I's.
TEST(DesignCheckValidation, an_fbar_design_deforms_like_calculixs_c3d8i_where_the_c3d8_element_locks) {
  const auto check = [](tissue::HexFormulation element, const std::string& name) {
    design::CaseFile c = pipeline::demo_case(2000);
    c.model = "neo-hookean";
    c.solve_mode = design::DesignSolveMode::Nonlinear;
    c.closed_loop = false;
    c.poisson_ratio = 0.49;
    c.element = element;
    pipeline::DesignArtifacts art;
    pipeline::run_design(c, run_dir(name) / "design", true, {}, &art);
    DesignCheckOptions o;
    o.mode = DesignCheckMode::Load;
    o.material = pipeline::fe_material(c);
    o.element = ElementType::C3D8I;
    const auto r = check_design(pipeline::designed_stump(art), o, run_dir(name + "_load"));
    EXPECT_TRUE(r.converged) << r.message;
    return r;
  };
  const auto fbar = check(tissue::HexFormulation::FBar, "design_fbar_2k");
  const auto full = check(tissue::HexFormulation::Full, "design_c3d8_2k");
  std::printf("[ info ] ν 0.49, C3D8I / socketsmith mean displacement: F-bar %.3f (MAE %.3f mm, R %.5f), C3D8 %.3f (MAE "
              "%.3f mm, R %.5f)\n",
              fbar.all.mean_a / fbar.all.mean_b, fbar.all.mae * 1e3, fbar.all.r, full.all.mean_a / full.all.mean_b,
              full.all.mae * 1e3, full.all.r);
  EXPECT_NEAR(fbar.all.mean_a / fbar.all.mean_b, 1.0, 0.05);  // measured 0.970 (C3D8: 1.225)
  EXPECT_GT(fbar.all.r, 0.995);  // measured 0.997 (C3D8: 0.991)
  EXPECT_GT(full.all.mean_a / full.all.mean_b, 1.08);  // C3D8 locks
  EXPECT_LT(fbar.all.mae, 0.5 * full.all.mae);
}

/// The embedded sample at @p nodes designed with tissue @p model, its socket donned from 60 mm below
/// with friction @p mu by socketsmith (linearised or nonlinear body) and by CalculiX (Poisson ratio
/// @p nu, NLGEOM unless @p small_strain), then, with @p stand, pushed with half the body weight in
/// both codes (the thesis's second step; CalculiX's push twice socketsmith's standing travel, compared where its
/// reaction reaches the load):
/// CalculiX's pressures against socketsmith's.
DesignCheckResult donning_against_calculix(const std::string& name, int nodes, const std::string& model, double mu,
                                           bool linear_body, double nu, bool stand = false, bool small_strain = false,
                                           const std::function<void(DesignCheckOptions&)>& tweak = {}) {
  const fs::path out = fs::path(SOCKETSMITH_BINARY_DIR) / "fe_test_runs" / name;
  auto c = plain_demo_case(nodes);
  c.model = model;
  pipeline::DesignArtifacts art;
  pipeline::run_design(c, out / "design", true, {}, &art);
  DesignedStump d = pipeline::designed_stump(art);
  contact::DonningOptions don;
  don.start_offset_m = 0.06;
  don.friction = mu;
  don.contact.linear_body = linear_body;
  don.stand_force_n = stand ? 0.5 * c.patient.body_mass_kg * units::kGravity : 0.0;
  const auto ours = pipeline::don_designed_socket(art, don);
  pipeline::use_donning_pressures(ours, d);
  DesignCheckOptions o;
  if (stand) {
    o.stand_force_n = don.stand_force_n;
    o.stand_travel_m = pipeline::calculix_stand_travel_m(ours);
  }
  o.nonlinear_geometry = !small_strain;
  o.mode = DesignCheckMode::Donning;
  o.material.youngs_modulus_pa = c.youngs_modulus_pa;
  o.material.density_kg_m3 = c.density_kg_m3;
  o.material.poisson_ratio = nu;
  o.contact.friction = mu;
  o.donning_travel_m = 0.06;
  if (tweak) tweak(o);
  return check_design(d, o, run_dir(name + "_fe"));
}

TEST(DesignCheckValidation, calculix_donning_agrees_with_socketsmiths_donning) {
  // The thesis's ch. 3 check (its R 0.77 on the whole surface): the designed socket donned from 60 mm
  // below, frictionless, in CalculiX and in socketsmith's contact solver, on the same 1.8k-node stump,
  // MSS-CS (measured 2026-11-25 with −n·σ·n: R 0.84, MAE 1.7 kPa; 3k nodes R 0.83; with the nodal
  // force: printed below). Nodal CPRESS gave R 0.14 here and depended on where the donning started.
  const auto r = donning_against_calculix("donning_1800", 1800, "mss-cs", 0.0, true, 0.25);
  ASSERT_TRUE(r.converged) << r.message;
  std::printf("[ info ] donning vs CalculiX donning, 1.8k nodes: means %.2f (CalculiX) / %.2f kPa, MAE %.2f kPa, p95 %.2f, R %.3f "
              "(-n.sigma.n R %.3f, CPRESS R %.3f); away from the brim MAE %.2f R %.3f\n",
              r.all.mean_a / 1e3, r.all.mean_b / 1e3, r.all.mae / 1e3, r.all.p95 / 1e3, r.all.r, r.all_stress.r,
              r.all_cpress.r, r.away_from_brim.mae / 1e3, r.away_from_brim.r);
  EXPECT_GT(r.all.r, 0.77);
  EXPECT_LT(r.all.mae, 2.5e3);
  EXPECT_LT(r.max_penetration_m, 0.5e-3);
}

TEST(DesignCheckValidation, with_the_fe_model_the_frictional_donnings_agree) {
  // The thesis's ch. 3 check with friction (its R 0.77; MSS-CS here: R 0.74 at 3k nodes): the fe
  // model's design of the 1.8k-node sample donned from 60 mm below with μ 0.5 by socketsmith
  // (nonlinear St Venant–Kirchhoff body) and by CalculiX (NLGEOM, the same material). Measured
  // 2026-11-25: 1.8k nodes R 0.936, MAE 0.61 kPa (means 6.41 / 6.34 kPa; with the socket
  // unsubdivided, before the sample asked for one subdivision: R 0.886, MAE 1.44); 3k nodes R 0.93,
  // MAE 0.97 kPa. socketsmith's linearised body (its donning default) against NLGEOM at 3k: R 0.94,
  // MAE 2.4 kPa, 27 % above CalculiX's level: with friction the geometric nonlinearity sets it.
  const auto r = donning_against_calculix("donning_fe_1800", 1800, "fe", 0.5, false, 0.45);
  ASSERT_TRUE(r.converged) << r.message;
  std::printf("[ info ] fe model, donning mu 0.5 vs CalculiX, 1.8k nodes: MAE %.2f kPa, R %.3f, means %.2f / %.2f kPa\n",
              r.all.mae / 1e3, r.all.r, r.all.mean_b / 1e3, r.all.mean_a / 1e3);
  EXPECT_GT(r.all.r, 0.90);
  EXPECT_LT(r.all.mae, 1.5e3);
}

TEST(DesignCheckValidation, the_closed_loop_socket_donned_and_stood_on_in_calculix_delivers_its_design) {
  // Issue 20's end-to-end check, reduced for CI: the sample at 1.8k nodes designed with the
  // neo-Hookean tissue (nonlinear solve), its socket corrected by the closed loop (2 donnings,
  // nonlinear body, μ 0.5), then donned 60 mm and stood on with half the body weight in CalculiX
  // (NEO HOOKE twin, ν 0.45, NLGEOM): CalculiX's pressures against the design and against
  // socketsmith's own donned-and-stood pressures. The default design (template-following PTB),
  // 2026-11-26: at 3k nodes, 4 donnings, CalculiX vs design MAE 1.19 kPa, p99 10.0, R 0.955 (means
  // 12.29 / 11.71 kPa); here, 1.8k nodes, 2 donnings (standing under displacement control, 2026-11-30): MAE
  // 1.14 kPa, p99 6.08, R 0.971 (means 12.39 / 11.87); CalculiX vs socketsmith MAE 1.25 kPa, R 0.938;
  // socketsmith's open loop MAE 3.45, R 0.830. 2026-12-01 (the smoothed wall fitted to the skin):
  // MAE 1.19, p99 5.92, R 0.969; CalculiX vs socketsmith MAE 1.27, p99 9.31, R 0.931. With the contact
  // penalty `validate design` gives a donning (socketsmith's own, 2.04e8 Pa/m here; since 2026-12-01):
  // MAE 1.01, p99 4.95, R 0.970, means 12.15 / 11.87; CalculiX vs socketsmith MAE 1.10, p99 8.13,
  // R 0.935; penetration 0.58 mm at most (0.25 with 1e9); CalculiX stands 1.40 mm past the pose
  // (socketsmith 1.08). With the shell split 2 x 2 and across the brim onto the lip (`validate
  // design`'s default since 2026-12-02): MAE 0.92, p99 4.63, R 0.972, means 12.06 / 11.87; CalculiX vs
  // socketsmith MAE 1.04, R 0.930; stood 1.36 mm; every landmark within 9 % (POP 0.275 → 0.299).
  // With socketsmith's pressures per deformed area (2026-12-04 night): MAE 0.87, p99 4.74, R 0.973,
  // means 12.05 / 11.87; CalculiX vs socketsmith MAE 0.93, R 0.929; POP 0.279 → 0.307 (+10 %).
  // Bars: issue 20's MAE (1.5 kPa) and, with a margin under the measured value, its R.
  design::CaseFile c = pipeline::demo_case(1800);
  c.model = "neo-hookean";
  c.solve_mode = design::DesignSolveMode::Nonlinear;
  c.closed_loop = true;
  c.closed_loop_donnings = 2;
  pipeline::DesignArtifacts art;
  pipeline::run_design(c, run_dir("closed_loop_nh_1800") / "design", true, {}, &art);
  ASSERT_TRUE(art.result.closed_loop.has_value());
  const auto& loop = *art.result.closed_loop;
  EXPECT_FALSE(loop.linear_body);
  ASSERT_GE(loop.donning.series.size(), 2u);
  const DesignedStump d = pipeline::designed_stump(art);
  ASSERT_EQ(d.wall_positions.size(), d.pressure_pa.size());  // CalculiX gets the corrected wall
  DesignCheckOptions o;
  o.mode = DesignCheckMode::Donning;
  o.material = pipeline::fe_material(c);
  ASSERT_TRUE(o.material.is_neo_hookean);
  o.contact.friction = c.patient.friction;
  o.donning_travel_m = 0.06;
  o.stand_force_n = 0.5 * c.patient.body_mass_kg * units::kGravity;
  o.stand_travel_m = pipeline::calculix_stand_travel_m(loop.donning);
  pipeline::DesignValidationOptions vo;  // `validate design CASE --mode donning --stand`'s penalty
  vo.mode = DesignCheckMode::Donning;
  o.contact.penalty_pa_per_m = pipeline::calculix_penalty_pa_per_m(c, vo, pipeline::socketsmith_penalty_pa_per_m(art));
  EXPECT_LT(o.contact.penalty_pa_per_m, 0.5e9);  // socketsmith's 20 E / h, not the deck's 1e9
  pipeline::calculix_shell(vo, true, o);  // and its shell: split 2 x 2, across the brim onto the lip
  EXPECT_TRUE(o.shell_lip);
  EXPECT_EQ(o.shell_subdivision, 2);
  const auto r = check_design(d, o, run_dir("closed_loop_nh_1800_fe"));
  ASSERT_TRUE(r.converged) << r.message;
  EXPECT_TRUE(r.stood);
  EXPECT_EQ(r.fe_alternating_nodes_first_try, -1);  // a smooth first try: no rerun for alternation
  EXPECT_LT(r.fe_alternating_nodes, o.alternation_rerun_nodes);
  std::printf("[ info ] CalculiX stood the socket %.2f mm past the designed pose (push %.2f mm, %d ccx run(s)); "
              "socketsmith %.2f mm\n", r.stand_offset_m * 1e3, r.stand_travel_m * 1e3, r.ccx_runs,
              pipeline::stand_offset_m(loop.donning) * 1e3);
  EXPECT_NEAR(r.fe_force_n, o.stand_force_n, 0.02 * o.stand_force_n);
  // Friction carries the same share of the standing load in both (the design's eq. 42 holds it at
  // μ Σ p A sin θ): 2026-12-01, CalculiX 74.5 % of the axial push its skin nodes feel (332 N: 3 %
  // short of its socket's reaction), socketsmith 75.8 %. A friction law that lost its slip
  // direction or its μ would move one of them by far more.
  const double fe_share = r.fe_axial_friction_n / r.fe_axial_force_n;
  const double our_share = loop.donning.series.back().axial_friction_n / loop.donning.series.back().axial_force_n;
  std::printf("[ info ] friction carries %.1f %% of the axial push in CalculiX (%.0f of %.0f N), %.1f %% in socketsmith\n",
              100 * fe_share, r.fe_axial_friction_n, r.fe_axial_force_n, 100 * our_share);
  EXPECT_NEAR(r.fe_axial_force_n, r.fe_force_n, 0.06 * r.fe_force_n);
  EXPECT_NEAR(fe_share, our_share, 0.05);
  std::vector<int> socket_nodes;
  for (size_t i = 0; i < r.brim_ring.size(); ++i)
    if (r.brim_ring[i] >= 1) socket_nodes.push_back(static_cast<int>(i));
  const auto ours = report::compare_fields(r.fe_value, loop.closed_loop_pa, socket_nodes);
  const auto open = report::compare_fields(loop.open_loop_pa, r.socketsmith_value, socket_nodes);
  std::printf("[ info ] closed loop, neo-Hookean, 1.8k: CalculiX vs design means %.2f / %.2f kPa, MAE %.2f, p99 %.2f, "
              "R %.3f; CalculiX vs socketsmith delivered means %.2f / %.2f, MAE %.2f, p99 %.2f, R %.3f; socketsmith's "
              "open loop vs design MAE %.2f, R %.3f\n",
              r.all.mean_a / 1e3, r.all.mean_b / 1e3, r.all.mae / 1e3, r.all.p99 / 1e3, r.all.r, ours.mean_a / 1e3,
              ours.mean_b / 1e3, ours.mae / 1e3, ours.p99 / 1e3, ours.r, open.mae / 1e3, open.r);
  // The two codes deliver the same pressures from the same socket...
  EXPECT_GT(ours.r, 0.92);
  EXPECT_LT(ours.mae, 1.5e3);
  EXPECT_NEAR(ours.mean_a, ours.mean_b, 0.1 * ours.mean_b);
  // ... and CalculiX's are the design's, far closer than the open-loop socket's were.
  EXPECT_GT(r.all.r, 0.94);
  EXPECT_LT(r.all.mae, 1.5e3);
  EXPECT_NEAR(r.all.mean_a, r.all.mean_b, 0.1 * r.all.mean_b);
  EXPECT_LT(r.all.mae, 0.5 * open.mae);
  EXPECT_LT(r.all.p99, 5.3e3);  // measured 4.63 kPa; 5.92 with the deck's penalty and the shell's sharp edge
  EXPECT_LT(r.max_penetration_m, 0.8e-3);  // measured 0.58 mm: one node at the brim, 118 kPa at 2.04e8 Pa/m
  // Each landmark's pressure / threshold over its zone, CalculiX's against the design's. Measured
  // (designed → CalculiX, 2026-12-02 with socketsmith's penalty and the lip): PT 0.072 → 0.078, MF
  // 0.284 → 0.298, LF 0.158 → 0.162, FH 0.372 → 0.383, POP 0.275 → 0.299, AD 0.095 → 0.094, TC 0.191 →
  // 0.198, the distal tip 0.034 → 0.036 (with 1e9 and no lip: MF 0.312, POP 0.308, the tip 0.027). Bar: issue 20's 10 %,
  // with a margin, and 0.01 of the threshold for the zones designed near zero.
  const auto& setup = *art.setup;
  const auto& area = setup.solver->skin().area_m2;
  std::vector<char> on_socket(r.brim_ring.size(), 0);
  for (int i : socket_nodes) on_socket[i] = 1;
  const auto zones = pipeline::landmark_zones(setup, on_socket);
  EXPECT_GE(zones.size(), 6u);
  std::vector<report::LandmarkRatio> ratios;
  for (const auto& z : zones) {
    const double threshold = z.mean(setup.thresholds, area);
    const double designed = z.mean(r.socketsmith_value, area) / threshold, fe = z.mean(r.fe_value, area) / threshold;
    std::printf("[ info ] landmark %s (%zu nodes): pressure / threshold designed %.3f, CalculiX %.3f\n", z.code.c_str(),
                z.nodes.size(), designed, fe);
    EXPECT_NEAR(fe, designed, 0.15 * designed + 0.01) << z.code;
    ratios.push_back({z.code, designed, fe});
  }
  // The verdict `validate design` writes (summary.json "bar"): the items held above hold in it too.
  const report::DeliveryVerdict v = report::judge_delivery(r.all, ratios);
  std::printf("[ info ] the delivery bar, CalculiX vs design: %s\n", v.summary().c_str());
  EXPECT_TRUE(v.mae_met && v.r_met) << v.summary();
  EXPECT_LE(v.worst_landmark_deviation, 0.2) << v.summary();  // measured 0.07 (PT; MF 0.12 with 1e9)
}

TEST(DesignCheckValidation, a_run_whose_pressure_alternates_node_by_node_is_run_again_with_shorter_increments) {
  // The rerun with real ccx, on the cheapest donning (600 nodes, frictionless, small strain): a margin
  // every node exceeds asks for it; the first try with increments of 50 %, the rerun (compared) with 25 %.
  const auto r = donning_against_calculix("alternation_600", 600, "mss-cs", 0.0, true, 0.25, false, true,
                                          [](DesignCheckOptions& o) {
                                            o.initial_increment = 0.5;
                                            o.alternation_margin_pa = -1e12;
                                          });
  ASSERT_TRUE(r.converged) << r.message;
  EXPECT_EQ(r.ccx_runs, 2);
  EXPECT_GT(r.ccx_total_wall_s, r.ccx.wall_s);  // both runs' time, not the last's alone
  EXPECT_GT(r.fe_alternating_nodes_first_try, 50);
  EXPECT_EQ(r.fe_alternating_nodes, r.fe_alternating_nodes_first_try);
  EXPECT_TRUE(fs::exists(r.deck.parent_path() / "design.alternating.log"));
  EXPECT_NE(read_text_file(r.deck).find("*STATIC\n0.25, 1., "), std::string::npos);
  EXPECT_GT(r.all.r, 0.5);  // compared on the rerun: a real result
}

// StandValidation (below) reduced for the default test run, which runs DesignCheckValidation.*: the
// same two steps on the sample at 600 nodes (49 s of CPU, ccx included). Measured (standing under
// displacement control, 2026-11-30): 604 nodes, R 0.896, MAE 1.51 kPa, means 12.60 (CalculiX) / 11.75
// kPa, contact force 343.5 N at the interpolated standing pose, penetration 0.20 mm; the bars are these
// with a margin, the force against M g / 2 of the sample's 70 kg.
TEST(DesignCheckValidation, reduced_the_fe_models_donning_and_standing_agree_with_a_small_strain_calculix) {
  const auto r = donning_against_calculix("stand_fe_600", 600, "fe", 0.5, true, 0.45, true, true);
  ASSERT_TRUE(r.converged) << r.message;
  // CalculiX reached the standing load on its push and is compared there (not at the push's end).
  EXPECT_TRUE(r.stood);
  EXPECT_DOUBLE_EQ(r.stand_reached_force_n, 0.5 * 70.0 * units::kGravity);
  EXPECT_GT(r.stand_offset_m, 0.0);
  EXPECT_LT(r.stand_offset_m, r.stand_travel_m);
  const double half_weight = 0.5 * 70.0 * units::kGravity;
  std::printf("[ info ] fe model, donning + standing vs small-strain CalculiX, %d nodes: MAE %.2f kPa, R %.3f, "
              "reaction %.1f N (M g / 2 = %.1f N), means %.2f / %.2f kPa, penetration %.2f mm\n",
              r.nodes, r.all.mae / 1e3, r.all.r, r.fe_force_n, half_weight, r.all.mean_a / 1e3, r.all.mean_b / 1e3,
              r.max_penetration_m * 1e3);
  EXPECT_NEAR(r.fe_force_n, half_weight, 0.02 * half_weight);
  EXPECT_GT(r.all.r, 0.85);
  EXPECT_LT(r.all.mae, 2.0e3);
  EXPECT_NEAR(r.all.mean_a, r.all.mean_b, 0.15 * r.all.mean_b);
  EXPECT_LT(r.max_penetration_m, 0.5e-3);
}

// Not in CI's reduced run (its pattern is DesignCheckValidation.*): ccx takes ~4 min here.
TEST(StandValidation, the_fe_models_donning_and_standing_agree_with_a_small_strain_calculix) {
  // The thesis's two FE steps, donning (μ 0.5) then half the body weight, on the fe model's design
  // of the 1.8k-node sample. Measured 2026-11-25: against a small-strain CalculiX R 0.94, MAE 0.86
  // kPa (front and back lines R 0.99); against NLGEOM R 0.44, MAE 2.9 kPa, CalculiX loading the
  // distal end twice as much (13.8 vs 6.5 kPa below 20 mm): socketsmith's donning body is linear,
  // and its nonlinear body (--nonlinear-body) does not converge under the standing push.
  const auto r = donning_against_calculix("stand_fe_1800", 1800, "fe", 0.5, true, 0.45, true, true);
  ASSERT_TRUE(r.converged) << r.message;
  std::printf("[ info ] fe model, donning + standing vs small-strain CalculiX, 1.8k nodes: MAE %.2f kPa, R %.3f\n",
              r.all.mae / 1e3, r.all.r);
  EXPECT_GT(r.all.r, 0.90);
  EXPECT_LT(r.all.mae, 1.5e3);
}

}  // namespace
}  // namespace socketsmith::calculix
