#include "socketsmith/tissue/cube_experiment.h"

#include <gtest/gtest.h>

#include <cmath>

#include "socketsmith/core/errors.h"
#include "socketsmith/tissue/spring_calibration.h"
#include "socketsmith/volume/box_mesher.h"

namespace socketsmith::tissue {
namespace {

CubeExperimentResult run(TissueModelKind kind, const CorrectiveSpringConstants& k, int divisions = 2) {
  CubeExperimentOptions o;
  o.divisions = divisions;
  o.model.kind = kind;
  o.model.corrective = k;
  return run_cube_experiment(o);
}

CubeExperimentResult run_checked(const CorrectiveSpringConstants& k) {
  CubeExperimentOptions o;
  o.divisions = 2;
  o.check_stability = true;
  o.model.corrective = k;
  return run_cube_experiment(o);
}

TEST(CubeExperiment, recommended_mss_cs_beats_the_thesis_and_stays_stable_to_64_percent_strain) {
  const auto r = run_checked(CorrectiveSpringConstants::recommended());
  ASSERT_TRUE(r.converged) << r.message;
  ASSERT_EQ(r.rows.size(), 17u);
  const auto e = cube_errors(r);
  // Measured 6.39 % and 2.56 % (docs/VALIDATION.md): short of the 5 % / 2 % targets, but
  // without the buckling that the thesis's constants show from 52 % strain.
  EXPECT_LT(e.max_displacement_error, 0.065);
  EXPECT_LT(e.max_volume_error, 0.026);
  EXPECT_FALSE(e.unstable);
  EXPECT_TRUE(std::isinf(e.first_unstable_strain));
  for (const auto& row : r.rows) {
    // equilibrium: the top reactions carry the box (nominal pressure = W/A), uniformly
    EXPECT_NEAR(row.top_pressure_pa, row.top_pressure_analytic_pa, 1e-6 * (1 + row.top_pressure_analytic_pa));
    EXPECT_LT(row.nodal_pressure_spread, 1e-6);
  }
}

TEST(CubeExperiment, cube_fit_constants_meet_the_five_and_two_percent_targets_on_a_stable_lattice) {
  // Measured 3.35 % and 1.34 % (docs/VALIDATION.md), stable over the whole range.
  const auto r = run_checked(CorrectiveSpringConstants::cube_fit());
  ASSERT_TRUE(r.converged) << r.message;
  ASSERT_EQ(r.rows.size(), 17u);
  const auto e = cube_errors(r);
  EXPECT_LT(e.max_displacement_error, 0.05);
  EXPECT_LT(e.max_volume_error, 0.02);
  EXPECT_FALSE(e.unstable);
  EXPECT_TRUE(std::isinf(e.first_unstable_strain));
}

TEST(CubeExperiment, cube_targets_constants_meet_the_targets_carry_the_sheared_cube_and_keep_the_linearisation) {
  // Measured 4.47 % and 1.77 % (docs/VALIDATION.md), stable over the whole range, the sheared cube
  // (7.5 + 1.5 kPa) carried, and recommended's A and spring ratio (its tangent at rest).
  const auto r = run_checked(CorrectiveSpringConstants::cube_targets());
  ASSERT_TRUE(r.converged) << r.message;
  const auto e = cube_errors(r);
  EXPECT_LT(e.max_displacement_error, 0.05);
  EXPECT_LT(e.max_volume_error, 0.02);
  EXPECT_FALSE(e.unstable);
  const auto cand = evaluate_constants(SpringCalibrationOptions{}, CorrectiveSpringConstants::cube_targets());
  ASSERT_TRUE(cand.shear_checked);
  EXPECT_TRUE(cand.sheared.converged) << cand.sheared.message;
  EXPECT_EQ(CorrectiveSpringConstants::cube_targets().golec_a, CorrectiveSpringConstants::recommended().golec_a);
  EXPECT_EQ(CorrectiveSpringConstants::cube_targets().spring_modulus_ratio,
            CorrectiveSpringConstants::recommended().spring_modulus_ratio);
  EXPECT_GT(CorrectiveSpringConstants::cube_targets().dead_zone, 0.01);
}

TEST(CubeExperiment, thesis_constants_reproduce_the_thesis_figures) {
  // Thesis (Figs. 29–30): displacement error ≤ 11 % up to 60 % strain, volume error ≤ 5 % at 40 %.
  const auto r = run_checked(CorrectiveSpringConstants::thesis());
  ASSERT_TRUE(r.converged) << r.message;
  const auto e = cube_errors(r);
  EXPECT_NEAR(e.max_displacement_error, 0.11, 0.02);
  EXPECT_NEAR(e.max_volume_error, 0.05, 0.01);
  // ... and its lattice loses stability (a stiffness eigenvalue turns negative) near 52 % strain.
  EXPECT_NEAR(e.first_unstable_strain, 0.52, 0.05);
}

TEST(CubeExperiment, mss_cf_conserves_volume_but_is_stiff_in_compression) {
  const auto r = run(TissueModelKind::MssCf, CorrectiveSpringConstants::thesis());
  ASSERT_TRUE(r.converged) << r.message;
  const auto e = cube_errors(r);
  EXPECT_LT(e.max_volume_error, 0.02);
  EXPECT_GT(e.max_displacement_error, 0.2);
  EXPECT_LT(r.rows.back().displacement_ratio, r.rows.back().displacement_ratio_analytic);  // stiffer
}

TEST(CubeExperiment, plain_mss_does_not_conserve_volume) {
  const auto r = run(TissueModelKind::Mss, CorrectiveSpringConstants::thesis());
  ASSERT_TRUE(r.converged) << r.message;
  EXPECT_GT(cube_errors(r).max_volume_error, 0.1);
}

TEST(CubeExperiment, result_does_not_depend_on_the_lattice_size) {
  // Frictionless top and bottom: the exact solution is homogeneous on any lattice.
  const auto a = run(TissueModelKind::MssCs, CorrectiveSpringConstants::recommended(), 1);
  const auto b = run(TissueModelKind::MssCs, CorrectiveSpringConstants::recommended(), 4);
  ASSERT_TRUE(a.converged && b.converged);
  for (size_t i = 0; i < a.rows.size(); ++i) {
    EXPECT_NEAR(a.rows[i].displacement_ratio, b.rows[i].displacement_ratio, 1e-7);
    EXPECT_NEAR(a.rows[i].volume_ratio, b.rows[i].volume_ratio, 1e-7);
  }
}

TEST(CubeExperiment, rejects_bad_options) {
  CubeExperimentOptions o;
  o.material.youngs_modulus_pa = -1;
  EXPECT_THROW(run_cube_experiment(o), InvalidInputError);
  o = {};
  o.edge_m = 0;
  EXPECT_THROW(run_cube_experiment(o), InvalidInputError);
}

TEST(SpringCalibration, improves_on_the_thesis_constants_from_their_own_starting_point) {
  SpringCalibrationOptions o;
  o.laws = {CorrectiveLaw::CompressionOnly};
  o.starts = 1;
  o.max_evaluations = 120;
  o.shear_check = false;  // tested below; keeps this test short
  const auto r = calibrate_corrective_springs(o);
  EXPECT_LT(r.best.objective, r.thesis.objective);
  EXPECT_LT(r.best.errors.max_displacement_error, r.thesis.errors.max_displacement_error);
  EXPECT_GT(r.evaluations, 10);
}

TEST(SpringCalibration, the_sheared_cube_requirement_rejects_constants_that_collapse_under_it) {
  SpringCalibrationOptions o;
  o.shear_check = false;
  const auto free = evaluate_constants(o, CorrectiveSpringConstants::cube_fit());
  EXPECT_FALSE(free.shear_checked);
  o.shear_check = true;
  o.sheared.compression_pa = 5e3;  // carried
  o.sheared.shear_pa = 1e3;
  const auto carried = evaluate_constants(o, CorrectiveSpringConstants::cube_fit());
  ASSERT_TRUE(carried.shear_checked);
  EXPECT_TRUE(carried.sheared.converged) << carried.sheared.message;
  EXPECT_DOUBLE_EQ(carried.objective, free.objective);
  o.sheared.compression_pa = 10e3;  // collapses at ≈ 75 % of it
  o.sheared.shear_pa = 2e3;
  const auto collapsed = evaluate_constants(o, CorrectiveSpringConstants::cube_fit());
  ASSERT_TRUE(collapsed.shear_checked);
  EXPECT_FALSE(collapsed.sheared.converged);
  EXPECT_GT(collapsed.objective, free.objective + 10.0);
}

TEST(SpringCalibration, fits_the_dead_zone_within_its_bounds_when_asked) {
  SpringCalibrationOptions o;
  o.laws = {CorrectiveLaw::CompressionOnly};
  o.starts = 1;
  o.max_evaluations = 25;
  o.shear_check = false;
  o.min_beta = 1.05;
  o.keep_linearisation_of = CorrectiveSpringConstants::recommended();
  o.min_dead_zone = 0.001;
  o.max_dead_zone = 0.03;
  const auto r = calibrate_corrective_springs(o);
  const auto& k = r.per_law.at(0).constants;
  EXPECT_GE(k.dead_zone, 0.001);
  EXPECT_LE(k.dead_zone, 0.03);
  EXPECT_NE(k.dead_zone, 0.5 * (0.001 + 0.03));  // moved from its start
  o.max_dead_zone = 0.6;
  EXPECT_THROW(calibrate_corrective_springs(o), InvalidInputError);
}

TEST(SpringCalibration, keeping_the_linearisation_leaves_the_tangent_at_rest_unchanged) {
  SpringCalibrationOptions o;
  o.laws = {CorrectiveLaw::CompressionOnly};
  o.starts = 1;
  o.max_evaluations = 20;
  o.shear_check = false;
  o.min_beta = 1.05;
  o.keep_linearisation_of = CorrectiveSpringConstants::recommended();
  const auto r = calibrate_corrective_springs(o);
  const auto& k = r.per_law.at(0).constants;
  EXPECT_DOUBLE_EQ(k.golec_a, o.keep_linearisation_of->golec_a);
  EXPECT_DOUBLE_EQ(k.spring_modulus_ratio, o.keep_linearisation_of->spring_modulus_ratio);
  EXPECT_NE(k.alpha, o.keep_linearisation_of->alpha);  // the corrective springs were fitted
  // The tangents at rest of the two models agree (the corrective springs add none there).
  const volume::HexMesh mesh = [] {
    volume::BoxMeshOptions b;
    b.size = volume::Vec3::Constant(0.02);
    b.divisions = {2, 2, 2};
    return volume::mesh_box(b);
  }();
  MassSpringOptions a, b;
  a.corrective = *o.keep_linearisation_of;
  b.corrective = k;
  const MassSpringModel ma(mesh, {50e3, 1060}, a), mb(mesh, {50e3, 1060}, b);
  SparseMatrix ja, jb;
  ma.jacobian(ma.rest_positions(), JacobianKind::Exact, ja);
  mb.jacobian(mb.rest_positions(), JacobianKind::Exact, jb);
  EXPECT_LT((Eigen::MatrixXd(ja) - Eigen::MatrixXd(jb)).norm(), 1e-9 * Eigen::MatrixXd(ja).norm());
  o.min_beta = 0.5;
  EXPECT_THROW(calibrate_corrective_springs(o), InvalidInputError);
}

}  // namespace
}  // namespace socketsmith::tissue
