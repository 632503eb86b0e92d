// The interactive design session without a window (socketsmith-gui draws one): undo and redo of
// several edits give back the exact case JSON of each step; the autosave is a case file that opens
// to the same case; the journal of a session's edits, replayed on a fresh session, gives the same
// socket as the edits made directly.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>

#include "socketsmith/design/case_file.h"
#include "socketsmith/pipeline/design_pipeline.h"
#include "socketsmith/pipeline/design_session.h"

namespace socketsmith::pipeline {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

constexpr int kNodes = 1500;
const fs::path kDir = fs::path(SOCKETSMITH_BINARY_DIR) / "tests" / "design_session";

/// A session on the demo limb at kNodes, its first solve done.
void open_demo(DesignSession& s, const fs::path& path = {}) {
  const design::CaseFile c = demo_case(kNodes);
  s.install(prepare_design(c), c, path);
  ASSERT_TRUE(s.wait_idle());
  ASSERT_TRUE(s.state().has_value());
}

json case_json(const DesignSession& s) { return design::case_to_json(s.document()); }

/// @p a and @p b hold the same keys and values, numbers within @p relative (a case file is in mm
/// and degrees, the session in SI: the round trip may move the last digit).
void expect_same_json(const json& a, const json& b, double relative, const std::string& where = "") {
  if (a.is_number() && b.is_number()) {
    const double x = a.get<double>(), y = b.get<double>();
    EXPECT_LE(std::abs(x - y), relative * std::max({std::abs(x), std::abs(y), 1e-300})) << where << ": " << x << " vs " << y;
    return;
  }
  ASSERT_EQ(a.type(), b.type()) << where;
  if (a.is_object()) {
    ASSERT_EQ(a.size(), b.size()) << where << ": " << a.dump() << " vs " << b.dump();
    for (const auto& [key, value] : a.items()) {
      ASSERT_TRUE(b.contains(key)) << where << "." << key;
      expect_same_json(value, b[key], relative, where + "." + key);
    }
  } else if (a.is_array()) {
    ASSERT_EQ(a.size(), b.size()) << where;
    for (size_t k = 0; k < a.size(); ++k) expect_same_json(a[k], b[k], relative, where + "[" + std::to_string(k) + "]");
  } else {
    EXPECT_EQ(a, b) << where;
  }
}

int last_spot(const DesignSession& s) { return static_cast<int>(s.document().spots.size()) - 1; }

TEST(DesignSession, undo_and_redo_of_several_edits_give_back_the_exact_case_json_of_each_step) {
  DesignSession s;
  open_demo(s);
  std::vector<json> steps{case_json(s)};
  s.add_spot_at_landmark("PT", design::SpotType::Cos2, 20e3);
  steps.push_back(case_json(s));
  s.set_spot_value(last_spot(s), "amplitude_kpa", 27.5);
  steps.push_back(case_json(s));
  s.set_thickness(6.5e-3);
  steps.push_back(case_json(s));
  s.set_brim_template(design::BrimTemplate::Kbm);
  steps.push_back(case_json(s));
  const auto key = s.setup()->brim.key_points().front();
  s.move_brim_key_point(0, key.theta, key.h - 0.004);
  steps.push_back(case_json(s));
  s.begin_edit();  // a slider drag: many values, one step
  for (double mm : {14.0, 13.0, 12.0}) s.set_spot_value(last_spot(s), "r_h_mm", mm);
  s.end_edit();
  steps.push_back(case_json(s));
  for (size_t k = 1; k < steps.size(); ++k) ASSERT_NE(steps[k], steps[k - 1]) << "edit " << k << " changed nothing";

  for (size_t k = steps.size() - 1; k > 0; --k) {
    ASSERT_TRUE(s.can_undo());
    s.undo();
    EXPECT_EQ(case_json(s), steps[k - 1]) << "undo to step " << k - 1;
  }
  EXPECT_FALSE(s.can_undo());
  for (size_t k = 1; k < steps.size(); ++k) {
    ASSERT_TRUE(s.can_redo());
    s.redo();
    EXPECT_EQ(case_json(s), steps[k]) << "redo to step " << k;
  }
  EXPECT_FALSE(s.can_redo());
  s.undo();  // a new edit after an undo drops what could be redone
  s.set_thickness(5e-3);
  EXPECT_FALSE(s.can_redo());
  ASSERT_TRUE(s.wait_idle());
  EXPECT_TRUE(s.errors().empty()) << s.errors().front();
}

TEST(DesignSession, the_autosave_is_written_once_due_and_opens_to_the_same_case) {
  fs::remove_all(kDir / "autosave");
  fs::create_directories(kDir / "autosave");
  const fs::path path = kDir / "autosave" / "case.json";
  // The interval counts from the session's start: take the clock before it, not after opening the
  // demo (which took over a minute under the sanitizers on shared cores, so the autosave was due).
  const auto start = std::chrono::steady_clock::now();
  DesignSession s;
  open_demo(s);
  s.save_case(path);
  EXPECT_FALSE(s.autosave(start + std::chrono::minutes(2))) << "nothing to save: no unsaved change";
  s.add_spot_at_landmark("PT", design::SpotType::Cos2, 25e3);
  s.set_spot_value(last_spot(s), "h0_mm", 60);
  s.set_thickness(7e-3);
  design::PatientLoad patient = s.document().patient;
  patient.body_mass_kg = 82;
  s.set_patient(patient, 120e3, s.document().thresholds);
  ASSERT_TRUE(s.is_dirty());
  EXPECT_EQ(s.autosave_path(), fs::path(path.string() + ".autosave.json"));
  EXPECT_FALSE(s.autosave(start + std::chrono::seconds(1), std::chrono::seconds(60))) << "not due yet";
  EXPECT_FALSE(fs::exists(s.autosave_path()));
  ASSERT_TRUE(s.autosave(start + std::chrono::seconds(120), std::chrono::seconds(60)));
  ASSERT_TRUE(fs::exists(s.autosave_path()));
  EXPECT_FALSE(s.autosave(start + std::chrono::seconds(121), std::chrono::seconds(60))) << "written a second ago";
  for (const auto& e : fs::directory_iterator(path.parent_path()))  // atomic: no temporary left
    EXPECT_TRUE(e.path() == path || e.path() == s.autosave_path()) << e.path();
  EXPECT_EQ(design::read_case(path).patient.body_mass_kg, 70) << "the case file itself is left alone";

  DesignSession reopened;
  reopened.open_case(s.autosave_path());
  ASSERT_TRUE(reopened.wait_idle());
  ASSERT_TRUE(reopened.has_design()) << (reopened.errors().empty() ? "" : reopened.errors().front());
  expect_same_json(case_json(reopened), case_json(s), 1e-12, "case");
  EXPECT_FALSE(reopened.is_dirty());
  ASSERT_TRUE(reopened.state().has_value());
  ASSERT_TRUE(s.wait_idle());
  EXPECT_EQ(reopened.document().spots.size(), s.document().spots.size());
  EXPECT_EQ(reopened.setup()->solver->model().num_nodes(), s.setup()->solver->model().num_nodes());
}

TEST(DesignSession, replaying_the_journal_of_the_edits_gives_the_same_socket_as_the_direct_edits) {
  DesignSession direct;
  open_demo(direct);
  const auto settle = [](DesignSession& s) { ASSERT_TRUE(s.wait_idle()); };
  direct.add_spot_at_landmark("PT", design::SpotType::Cos2, 20e3);
  settle(direct);
  direct.set_spot_value(last_spot(direct), "amplitude_kpa", 31);
  settle(direct);
  const double length = direct.setup()->model.length_m;
  direct.add_spot_at(skin_point(*direct.setup(), 2.0, 0.45 * length), design::SpotType::Sig2, 15e3);
  settle(direct);
  direct.set_spot_value(last_spot(direct), "h2_mm", 0.5 * length * 1e3);
  settle(direct);
  direct.set_thickness(6e-3);
  settle(direct);
  const auto key = direct.setup()->brim.key_points().back();
  direct.move_brim_key_point(static_cast<int>(direct.setup()->brim.key_points().size()) - 1, key.theta,
                             key.h + 0.003);
  settle(direct);
  direct.set_spot_value(0, "amplitude_kpa", 5);
  settle(direct);
  direct.undo();  // the amplitude of spot 0 comes back
  settle(direct);
  direct.begin_edit();
  for (double kpa : {36.0, 38.0, 40.0}) direct.set_spot_value(1, "amplitude_kpa", kpa);
  direct.end_edit();
  settle(direct);
  direct.set_spot_freedom(0, false, true);
  direct.remove_spot(2);
  settle(direct);
  const json journal = direct.journal();
  ASSERT_GE(journal.size(), 12u) << journal.dump();

  DesignSession replayed;
  open_demo(replayed);
  for (const json& action : journal) {
    replayed.apply(action);
    settle(replayed);
  }
  EXPECT_TRUE(direct.errors().empty() && replayed.errors().empty());
  EXPECT_EQ(replayed.journal().size(), journal.size());  // the replay records the same edits
  for (size_t k = 0; k < std::min(journal.size(), replayed.journal().size()); ++k)
    EXPECT_EQ(replayed.journal()[k]["do"], journal[k]["do"]);

  // The same design: spots and wall as edited.
  const auto& a = direct.document(), & b = replayed.document();
  ASSERT_EQ(a.spots.size(), b.spots.size());
  for (size_t k = 0; k < a.spots.size(); ++k) {
    EXPECT_EQ(a.spots[k].name, b.spots[k].name);
    EXPECT_NEAR(a.spots[k].amplitude_pa, b.spots[k].amplitude_pa, 1e-9);
    EXPECT_NEAR(a.spots[k].theta0, b.spots[k].theta0, 1e-12);
    EXPECT_NEAR(a.spots[k].h0, b.spots[k].h0, 1e-12);
    EXPECT_NEAR(a.spots[k].h2, b.spots[k].h2, 1e-12);
    EXPECT_EQ(a.spots[k].optimise_amplitude, b.spots[k].optimise_amplitude);
  }
  EXPECT_EQ(a.socket.thickness_m, b.socket.thickness_m);
  // The same socket: triangles and vertex positions.
  const geometry::TriMesh sa = direct.socket_preview(), sb = replayed.socket_preview();
  ASSERT_GT(sa.triangles.size(), 0u);
  ASSERT_EQ(sa.triangles.size(), sb.triangles.size());
  ASSERT_EQ(sa.vertices.size(), sb.vertices.size());
  double worst = 0;
  for (size_t i = 0; i < sa.vertices.size(); ++i) worst = std::max(worst, (sa.vertices[i] - sb.vertices[i]).norm());
  EXPECT_LT(worst, 1e-9) << "largest vertex distance [m]";
  EXPECT_EQ(sa.triangles, sb.triangles);
  EXPECT_NEAR(direct.state()->radar.force_n.z(), replayed.state()->radar.force_n.z(), 1e-6);
}

// The delivery check (issue 20: "the closed loop runs on release"): asked for, it runs once the
// design has settled — on the design shown: its targets are the shown state's pressures below the
// brim — and closes the loop (the corrected socket delivers the design far better than the open-
// loop one). An edit while it runs stops it: the check installed is of the edited design, and the
// one stopped is never installed. A design without a socket (a constraint not met) is not checked.
TEST(DesignSession, the_delivery_check_closes_the_loop_of_the_shown_design_and_an_edit_restarts_it) {
  DesignSession s;
  open_demo(s);
  s.optimise();
  ASSERT_TRUE(s.wait_idle());
  ASSERT_TRUE(s.state()->status.all_ok());
  s.ask_delivery();
  s.poll();
  ASSERT_TRUE(s.is_checking_delivery()) << "a settled design with a socket is checked at once";
  EXPECT_FALSE(s.is_idle());
  s.set_thickness(0.006);  // a new design (its state solved again) while the check runs
  ASSERT_TRUE(s.wait_idle(std::chrono::minutes(3)));
  ASSERT_EQ(s.delivery_error(), "");
  const DeliveryCheck* d = s.delivery();
  ASSERT_NE(d, nullptr);
  EXPECT_EQ(s.delivery_serial(), 1u) << "the check stopped by the edit was installed";
  EXPECT_EQ(d->state, s.state_serial()) << "the check is not of the design shown";
  // Its targets are the shown design's pressures below the brim.
  const auto& shown = s.state()->pressure_pa;
  ASSERT_EQ(d->target_pa.size(), shown.size());
  int compared = 0;
  double worst = 0;
  for (size_t i = 0; i < shown.size(); ++i) {
    if (!d->below_brim[i]) continue;
    ++compared;
    worst = std::max(worst, std::abs(d->target_pa[i] - shown[i]));
  }
  EXPECT_GT(compared, 100);
  EXPECT_LT(worst, 1.0) << "largest difference of the check's target from the shown design [Pa]";
  // The loop closed: below the brim the corrected socket is within the loop's tolerances.
  const auto below = std::find_if(d->summary.regions.begin(), d->summary.regions.end(),
                                  [](const RegionDelivery& r) { return r.key == "below_brim"; });
  ASSERT_NE(below, d->summary.regions.end());
  std::printf("[ measured ] delivery check: %d donnings + %d refits, %.1f s; below the brim MAE %.2f -> %.2f kPa, "
              "p99 %.2f -> %.2f kPa, R %.3f -> %.3f\n",
              d->donnings, d->refits, d->seconds, below->open_loop.mae / 1e3, below->closed_loop.mae / 1e3,
              below->open_loop.p99 / 1e3, below->closed_loop.p99 / 1e3, below->open_loop.r, below->closed_loop.r);
  EXPECT_GE(d->donnings, 2);
  EXPECT_LT(below->closed_loop.mae, 0.5 * below->open_loop.mae);
  EXPECT_LT(below->closed_loop.mae, 1000.0);
  EXPECT_GT(below->closed_loop.r, 0.95);
  EXPECT_FALSE(d->summary.landmarks.empty());

  // A constraint broken: no socket, so no check (the last one stays, of the design before).
  s.set_spot_value(0, "amplitude_kpa", 3 * s.document().spots[0].amplitude_pa / 1e3 + 20.0);
  ASSERT_TRUE(s.wait_idle());
  ASSERT_FALSE(s.state()->status.all_ok());
  EXPECT_FALSE(s.is_checking_delivery());
  ASSERT_NE(s.delivery(), nullptr);
  EXPECT_NE(s.delivery()->state, s.state_serial());
  EXPECT_EQ(s.delivery_serial(), 1u);
}

}  // namespace
}  // namespace socketsmith::pipeline
