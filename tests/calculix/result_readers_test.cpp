// The readers on excerpts of files written by ccx 2.20 (a one-element cube under a rigid plate;
// the deck is in calculix_deck_test's style), cut to a few records.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "socketsmith/core/errors.h"
#include "socketsmith/calculix/dat_reader.h"
#include "socketsmith/calculix/design_check.h"
#include "socketsmith/calculix/frd_reader.h"

namespace socketsmith::calculix {
namespace {

const char* kFrd = R"(    1C
    1UVERSION           Version 2.20                             
    2C                            3                                     1
 -1         1 0.00000E+00 0.00000E+00 0.00000E+00
 -1         2 1.00000E+00 0.00000E+00 0.00000E+00
 -1        11-5.00000E-01-5.00000E-01 1.00000E+00
 -3
    3C                             1                                     1
 -1         1    1    0    1
 -2         1         2         3         4         5         6         7         8
 -3
    1PSTEP                         1           1           1          
  100CL  101 2.50000E-01           3                     0    1           1
 -4  DISP        4    1
 -5  D1          1    2    1    0
 -5  D2          1    2    2    0
 -5  D3          1    2    3    0
 -5  ALL         1    2    0    0    1ALL
 -1         1 0.00000E+00 0.00000E+00 0.00000E+00
 -1         2 7.50000E-04 0.00000E+00 0.00000E+00
 -1        11 0.00000E+00 0.00000E+00-2.50025E-03
 -3
    1PSTEP                         3           1           1          
  100CL  101 2.50000E-01           3                     0    1           1
 -4  CONTACT     6    1
 -5  COPEN       1    4    1    1
 -5  CSLIP1      1    4    2    2
 -5  CSLIP2      1    4    3    3
 -5  CPRESS      1    4    1    2
 -5  CSHEAR1     1    4    2    3
 -5  CSHEAR2     1    4    3    1
 -1         1 0.00000E+00 0.00000E+00 0.00000E+00 0.00000E+00 0.00000E+00 0.00000E+00
 -1         2-2.50000E-07 0.00000E+00 0.00000E+00 2.50000E+02 0.00000E+00 0.00000E+00
 -3
    1PSTEP                         5           2           1          
  100CL  102 5.00000E-01           3                     0    2           1
 -4  DISP        4    1
 -5  D1          1    2    1    0
 -5  D2          1    2    2    0
 -5  D3          1    2    3    0
 -5  ALL         1    2    0    0    1ALL
 -1         1 0.00000E+00 0.00000E+00 0.00000E+00
 -1         2 1.50000E-03 0.00000E+00 0.00000E+00
 -1        11 0.00000E+00 0.00000E+00-5.00066E-03
 -3
 9999
)";

const char* kDat = R"(
 displacements (vx,vy,vz) for set REF and time  0.2500000E+00

    900001  0.000000E+00  0.000000E+00 -2.500250E-03

 forces (fx,fy,fz) for set REF and time  0.2500000E+00

    900001  0.000000E+00  8.496473E-16 -2.500000E+02


 statistics for slave set SLIMB, master set SSOCK and time  0.2500000E+00

   total surface force (fx,fy,fz) and moment about the origin (mx,my,mz)

    0.000000E+00  8.496473E-16 -2.500000E+02 -1.250938E+02  1.250938E+02  6.496762E-16

   center of gravity and mean normal

    5.003750E-01  5.003750E-01  9.975000E-01  0.000000E+00 -3.398589E-18  1.000000E+00

   moment about the center of gravity(mx,my,mz)

   -2.401193E-09 -1.164452E-09  2.245340E-16

   area,  normal force (+ = tension) and shear force (size)

    1.000000E+00 -2.500000E+02  9.561586E-26

 forces (fx,fy,fz) for set REF and time  0.5000000E+00

    900001  0.000000E+00  1.284750E-15 -5.000000E+02
)";

TEST(FrdReader, nodes_and_blocks_of_every_increment) {
  const auto r = parse_frd(kFrd, "fixture");
  ASSERT_EQ(r.node_ids.size(), 3u);
  EXPECT_EQ(r.node_ids[2], 11);
  EXPECT_DOUBLE_EQ(r.node_positions[2].x(), -0.5);
  EXPECT_DOUBLE_EQ(r.node_positions[2].z(), 1.0);
  ASSERT_EQ(r.blocks.size(), 3u);
  const auto* c = r.last("CONTACT");
  ASSERT_NE(c, nullptr);
  EXPECT_EQ(c->components.size(), 6u);
  EXPECT_EQ(c->component_index("CPRESS"), 3);
  EXPECT_DOUBLE_EQ(c->time, 0.25);
  const auto p = c->dense("CPRESS", 11);
  EXPECT_DOUBLE_EQ(p[1], 250.0);
  EXPECT_DOUBLE_EQ(p[0], 0.0);
  EXPECT_DOUBLE_EQ(c->dense("COPEN", 11)[1], -2.5e-7);
  const auto* d = r.last("DISP");
  ASSERT_NE(d, nullptr);
  EXPECT_EQ(d->increment, 2);
  EXPECT_EQ(d->step, 1);
  EXPECT_DOUBLE_EQ(d->time, 0.5);
  EXPECT_EQ(d->components, (std::vector<std::string>{"D1", "D2", "D3"}));
  EXPECT_DOUBLE_EQ(d->dense("D3", 11)[10], -5.00066e-3);
  EXPECT_DOUBLE_EQ(d->dense("D1", 11)[1], 1.5e-3);
  EXPECT_THROW(d->dense("CPRESS", 11), InvalidInputError);
  EXPECT_EQ(r.last("STRESS"), nullptr);
}

TEST(FrdReader, malformed_and_truncated_files_are_errors) {
  std::string bad = kFrd;
  bad.replace(bad.find("2.50000E+02"), 11, "2.5000xE+02");
  EXPECT_THROW(parse_frd(bad, "bad"), InvalidInputError);
  std::string cut(kFrd);
  cut = cut.substr(0, cut.find(" -1         2-2.50000E-07")) + " -1         2-2.50000E-07 0.00000E+00\n -3\n";
  EXPECT_THROW(parse_frd(cut, "cut"), InvalidInputError);
  EXPECT_THROW(read_frd("/nonexistent/job.frd"), IoError);
}

TEST(DatReader, node_prints_and_contact_statistics) {
  const auto b = parse_dat(kDat, "fixture");
  ASSERT_EQ(b.size(), 4u);
  EXPECT_EQ(b[0].title, "displacements (vx,vy,vz)");
  EXPECT_EQ(b[0].set, "REF");
  EXPECT_DOUBLE_EQ(b[0].time, 0.25);
  ASSERT_EQ(b[0].rows.size(), 1u);
  EXPECT_DOUBLE_EQ(b[0].rows[0][0], 900001);
  EXPECT_DOUBLE_EQ(b[0].rows[0][3], -2.50025e-3);
  EXPECT_EQ(b[2].title, "statistics");
  EXPECT_EQ(b[2].set, "SLIMB");
  ASSERT_EQ(b[2].rows.size(), 4u);
  EXPECT_DOUBLE_EQ(b[2].rows[0][2], -250.0);
  EXPECT_DOUBLE_EQ(b[2].rows[3][0], 1.0);   // contact area
  EXPECT_DOUBLE_EQ(b[2].rows[3][1], -250);  // normal force
  const auto* f = last_block(b, "forces", "ref");
  ASSERT_NE(f, nullptr);
  EXPECT_DOUBLE_EQ(f->time, 0.5);
  EXPECT_DOUBLE_EQ(f->rows[0][3], -500.0);
  EXPECT_EQ(last_block(b, "forces", "BONE"), nullptr);
  // The block of one increment by its total time (the end of a step): the standing check's retry
  // reads CalculiX's own reaction at the end of step 1 this way.
  const auto* q = block_at(b, "forces", "REF", 0.25);
  ASSERT_NE(q, nullptr);
  EXPECT_DOUBLE_EQ(q->rows[0][3], -250.0);
  EXPECT_EQ(block_at(b, "forces", "REF", 1.0), nullptr);
  EXPECT_EQ(block_at(b, "statistics", "REF", 0.25), nullptr);
}

/// A .dat of the reference node from @p rows (time, force along z, displacement along z).
std::string reference_dat(const std::vector<std::array<double, 3>>& rows) {
  std::string dat;
  for (const auto& [t, f, u] : rows) {
    dat += fmt::format(" displacements (vx,vy,vz) for set REF and time  {:.7E}\n\n    900001  0.000000E+00  0.000000E+00  {:.7E}\n\n", t, u);
    dat += fmt::format(" forces (fx,fy,fz) for set REF and time  {:.7E}\n\n    900001  3.000000E+00  1.600000E+01  {:.7E}\n\n", t, f);
  }
  return dat;
}

// CalculiX's standing step under displacement control: the state compared is interpolated between
// the first two increments whose reactions bracket the load (step 1's end counts: time 1), the pose
// past the donned one with it. A reaction that dips first (friction turning, the 2k thigh: 147 → 135 N)
// is not a crossing.
TEST(DatReader, the_standing_pose_is_where_the_reference_nodes_reaction_reaches_the_load) {
  const auto dat = parse_dat(reference_dat({{0.9, 100, 0.054}, {1.0, 147, 0.06}, {1.1, 135, 0.0604}, {1.2, 200, 0.0608},
                                            {1.35, 300, 0.0614}, {1.5, 400, 0.062}, {1.7, 390, 0.0628}}),
                             "fixture");
  auto p = standing_pose(dat, 343.2, Vec3::UnitZ());
  EXPECT_DOUBLE_EQ(p.donned_force_n, 147);
  ASSERT_TRUE(p.reached);
  EXPECT_DOUBLE_EQ(p.time_a, 1.35);
  EXPECT_DOUBLE_EQ(p.time_b, 1.5);
  EXPECT_NEAR(p.weight, 0.432, 1e-12);
  EXPECT_NEAR(p.displacement_m, 0.0014 + 0.432 * 0.0006, 1e-12);
  EXPECT_DOUBLE_EQ(p.last_time, 1.7);
  EXPECT_NEAR(p.last_displacement_m, 0.0028, 1e-12);
  // Along a slanted load direction the force is the row's projection on it.
  const Vec3 dir(0, 0.6, 0.8);
  p = standing_pose(dat, 0.6 * 16 + 0.8 * 400, dir);
  ASSERT_TRUE(p.reached);
  EXPECT_DOUBLE_EQ(p.time_b, 1.5);
  EXPECT_NEAR(p.weight, 1.0, 1e-12);
  // A socket that carried more than the load when donned, pushed back down: the crossing downwards.
  p = standing_pose(parse_dat(reference_dat({{1.0, 405, 0.03}, {1.2, 380, 0.0296}, {1.4, 330, 0.0292}}), "f"), 343.2,
                    Vec3::UnitZ());
  ASSERT_TRUE(p.reached);
  EXPECT_DOUBLE_EQ(p.time_a, 1.2);
  EXPECT_NEAR(p.weight, (380 - 343.2) / 50, 1e-12);
  EXPECT_NEAR(p.displacement_m, -0.0004 - 0.0004 * (380 - 343.2) / 50, 1e-12);
  // Step 1 never ended: nothing stood, and no rerun can help.
  p = standing_pose(parse_dat(reference_dat({{0.9, 100, 0.054}}), "f"), 343.2, Vec3::UnitZ());
  EXPECT_FALSE(p.reached);
  EXPECT_TRUE(std::isnan(p.donned_force_n));
  EXPECT_TRUE(std::isnan(standing_retry_travel_m(p, 0.004, 343.2)));
}

// A push that did not reach the load is run again: further the same way when it ran to its end
// (the gain extrapolated ×1.5, 1.5 to 4 times the travel), the other way when the donned socket was
// already past the load (as far as the step's stiffness asks, ×1.5); not when ccx gave up on the way.
TEST(DatReader, a_standing_push_short_of_the_load_is_retried_from_calculix_own_reactions) {
  // The 2k thigh (2026-11-30): 147 N donned, 243 N 2.43 mm further; the load 343.2 N.
  auto p = standing_pose(parse_dat(reference_dat({{1.0, 147.3, 0.06}, {1.5, 181.7, 0.0612}, {2.0, 242.7, 0.06243}}), "f"),
                         343.2, Vec3::UnitZ());
  EXPECT_FALSE(p.reached);
  EXPECT_NEAR(standing_retry_travel_m(p, 0.00243, 343.2), 0.00243 * 1.5 * (343.2 - 147.3) / (242.7 - 147.3), 1e-12);
  // Pushed on while the donned socket already carried 384 N: back down, 1.5 × 40.8 N over the step's 20 N/mm.
  p = standing_pose(parse_dat(reference_dat({{1.0, 384, 0.03}, {2.0, 404, 0.031}}), "f"), 343.2, Vec3::UnitZ());
  EXPECT_NEAR(standing_retry_travel_m(p, 0.001, 343.2), -1.5 * 40.8 / 20e3, 1e-12);
  // ccx stopped at time 1.4 short of the load: it would stop there again.
  p = standing_pose(parse_dat(reference_dat({{1.0, 147.3, 0.06}, {1.4, 181.7, 0.061}}), "f"), 343.2, Vec3::UnitZ());
  EXPECT_TRUE(std::isnan(standing_retry_travel_m(p, 0.0025, 343.2)));
  // A push that gained nothing: twice as far.
  p = standing_pose(parse_dat(reference_dat({{1.0, 147.3, 0.06}, {2.0, 140, 0.061}}), "f"), 343.2, Vec3::UnitZ());
  EXPECT_NEAR(standing_retry_travel_m(p, 0.001, 343.2), 0.002, 1e-15);
}

// A socket axis off the global z with a *TRANSFORM on the reference node: ccx prints its rows in the
// local system, each ended by "L" (OpenLimbTF, 2026-11-30: the rows were dropped).
TEST(DatReader, rows_in_a_nodes_local_system_are_read_and_marked) {
  const char* local = R"(
 forces (fx,fy,fz) for set REF and time  0.1000000E+01

    900001 -5.975673E+00 -3.387061E+00  1.472898E+02 L
)";
  const auto l = parse_dat(local, "fixture");
  ASSERT_EQ(l.size(), 1u);
  ASSERT_EQ(l[0].rows.size(), 1u);
  EXPECT_TRUE(l[0].local);
  EXPECT_DOUBLE_EQ(l[0].rows[0][3], 147.2898);
  EXPECT_FALSE(parse_dat(reference_dat({{1.0, 147, 0.06}}), "f")[0].local);
  EXPECT_THROW(parse_dat(" forces (fx,fy,fz) for set REF and time  0.1E+01\n 900001 1.0 L 2.0\n", "x").at(0).rows.at(0),
               std::out_of_range);  // "L" only at the end of a row
}

}  // namespace
}  // namespace socketsmith::calculix
