// Brim lines: template names, placement from landmarks on a generated limb, clamping, editing,
// validation against the skin, above-brim tests.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <numbers>

#include "socketsmith/core/errors.h"
#include "socketsmith/core/units.h"
#include "socketsmith/design/brim.h"
#include "socketsmith/volume/limb_generator.h"
#include "socketsmith/volume/limb_model.h"

namespace socketsmith::design {
namespace {

using geometry::LimbType;
constexpr double kDeg = units::deg, kMm = units::mm;

const volume::GeneratedLimb& tt_limb() {
  static const volume::GeneratedLimb limb = volume::generate_limb(volume::default_params(LimbType::Transtibial, 0));
  return limb;
}
const volume::GeneratedLimb& tf_limb() {
  static const volume::GeneratedLimb limb = volume::generate_limb(volume::default_params(LimbType::Transfemoral, 0));
  return limb;
}
double lm_h(const volume::GeneratedLimb& l, const std::string& code) {
  for (const auto& m : l.landmarks)
    if (m.code == code) return m.cylindrical.h;
  ADD_FAILURE() << "no landmark " << code;
  return 0;
}
double lm_theta(const volume::GeneratedLimb& l, const std::string& code) {
  for (const auto& m : l.landmarks)
    if (m.code == code) return m.cylindrical.theta;
  ADD_FAILURE() << "no landmark " << code;
  return 0;
}
std::string message_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const Error& e) {
    return e.what();
  }
  return "(no error)";
}

TEST(BrimTemplate, names_round_trip_and_unknown_names_list_the_valid_ones) {
  for (auto k : {BrimTemplate::Ptb, BrimTemplate::PtbSc, BrimTemplate::PtbScsp, BrimTemplate::Kbm, BrimTemplate::Tsb,
                 BrimTemplate::Quad, BrimTemplate::Ics, BrimTemplate::Custom})
    EXPECT_EQ(parse_brim_template(to_string(k)), k);
  EXPECT_EQ(parse_brim_template("PTB-SC"), BrimTemplate::PtbSc);
  EXPECT_EQ(parse_brim_template("Quadrilateral"), BrimTemplate::Quad);  // the full name is the quad template
  const std::string msg = message_of([] { parse_brim_template("ptbb"); });
  EXPECT_NE(msg.find("'ptbb'"), std::string::npos) << msg;
  EXPECT_NE(msg.find("ptb, ptb-sc, ptb-scsp, kbm, tsb, quad, ics"), std::string::npos) << msg;
  EXPECT_EQ(limb_type_of(BrimTemplate::Kbm), LimbType::Transtibial);
  EXPECT_EQ(limb_type_of(BrimTemplate::Ics), LimbType::Transfemoral);
}

TEST(BrimTemplate, a_template_of_the_other_limb_type_is_a_clear_error) {
  const auto& l = tt_limb();
  const std::string msg = message_of([&] { make_brim(BrimTemplate::Quad, LimbType::Transtibial, l.landmarks, l.cut_height_m); });
  EXPECT_NE(msg.find("transfemoral template but the limb is transtibial"), std::string::npos) << msg;
  EXPECT_NE(msg.find("ptb, ptb-sc, ptb-scsp, kbm, tsb"), std::string::npos) << msg;
  EXPECT_THROW(make_brim(BrimTemplate::Ptb, LimbType::Transfemoral, tf_limb().landmarks, tf_limb().cut_height_m),
               InvalidInputError);
  EXPECT_THROW(make_brim(BrimTemplate::Custom, LimbType::Transtibial, l.landmarks, l.cut_height_m), InvalidInputError);
  const std::string missing = message_of([&] { make_brim(BrimTemplate::Ptb, LimbType::Transtibial, {}, l.cut_height_m); });
  EXPECT_NE(missing.find("needs landmark PT"), std::string::npos) << missing;
}

TEST(BrimTemplate, transtibial_templates_have_the_shapes_of_their_socket_types) {
  const auto& l = tt_limb();
  const double pt = lm_h(l, "PT"), knee = lm_h(l, "POP") + 10 * kMm, cut = l.cut_height_m;
  auto make = [&](BrimTemplate k) { return make_brim(k, LimbType::Transtibial, l.landmarks, cut); };
  for (auto k : {BrimTemplate::Ptb, BrimTemplate::PtbSc, BrimTemplate::PtbScsp, BrimTemplate::Kbm, BrimTemplate::Tsb}) {
    const BrimLine b = make(k);
    EXPECT_GE(b.key_points().size(), 8u);
    EXPECT_LE(b.key_points().size(), 12u);
    for (const auto& p : b.key_points()) {
      EXPECT_LE(p.h, cut - 5 * kMm + 1e-12) << to_string(k) << " " << p.label;
      EXPECT_GE(p.h, 0.4 * cut - 1e-12) << to_string(k) << " " << p.label;
    }
    EXPECT_LE(b.max_height(), cut - 5 * kMm + 1e-4) << to_string(k);  // Akima: no overshoot to speak of
    // Posterior lower than the medial/lateral walls in every transtibial type (knee flexion).
    EXPECT_LT(b.height(std::numbers::pi), b.height(80 * kDeg)) << to_string(k);
    EXPECT_LT(b.height(std::numbers::pi), b.height(-80 * kDeg)) << to_string(k);
  }
  const BrimLine ptb = make(BrimTemplate::Ptb), sc = make(BrimTemplate::PtbSc), scsp = make(BrimTemplate::PtbScsp),
                 kbm = make(BrimTemplate::Kbm), tsb = make(BrimTemplate::Tsb);
  EXPECT_NEAR(ptb.height(0), pt + 30 * kMm, 1e-12);                 // mid-patella
  EXPECT_GT(ptb.height(80 * kDeg), knee);                           // wings above the joint line
  EXPECT_GT(sc.height(80 * kDeg), ptb.height(80 * kDeg) + 20 * kMm);  // supracondylar wings
  EXPECT_GT(scsp.height(0), ptb.height(0) + 15 * kMm);              // covers the patella
  EXPECT_LT(kbm.height(0), ptb.height(0));                          // patella free
  EXPECT_GT(kbm.height(80 * kDeg), ptb.height(80 * kDeg));
  EXPECT_LT(tsb.max_height() - tsb.min_height(), 30 * kMm);         // nearly level
  EXPECT_GT(tsb.min_height(), ptb.min_height());
}

TEST(BrimTemplate, the_curve_between_clamped_key_points_stays_below_the_top_margin) {
  // A short stump clamps several key points to the same height (cut − 5 mm); the periodic Akima
  // spline through them then bulged above it — by 5.5 mm on generated limb 1 cut at 130 mm with
  // KBM, whose socket build failed ("the brim reaches h = 130.5 mm, above the top of the stump
  // surface") in the 200-case sweep of docs/sweep.md. The whole curve must keep the margin.
  int clamped_cases = 0;
  for (std::uint64_t seed = 1; seed <= 5; ++seed) {
    const auto limb = volume::generate_limb(volume::default_params(LimbType::Transtibial, seed));
    for (double cut_mm : {120.0, 130.0, 140.0, 150.0, 170.0}) {
      const double cut = std::min(cut_mm * kMm, limb.cut_height_m);
      for (auto k : {BrimTemplate::Ptb, BrimTemplate::PtbSc, BrimTemplate::PtbScsp, BrimTemplate::Kbm, BrimTemplate::Tsb}) {
        std::vector<std::string> notes;
        const BrimLine b = make_brim(k, LimbType::Transtibial, limb.landmarks, cut, {}, &notes);
        if (!notes.empty()) ++clamped_cases;
        EXPECT_LE(b.max_height(), cut - 5 * kMm + 1e-9)
            << to_string(k) << ", seed " << seed << ", cut " << cut_mm << " mm: curve at " << b.max_height() / kMm;
        for (const auto& p : b.key_points()) EXPECT_GE(p.h, 0.4 * cut - 1e-12) << to_string(k) << " " << p.label;
      }
    }
  }
  EXPECT_GT(clamped_cases, 20);  // the short cuts do clamp: the case above is exercised
  // The sweep's case itself, through the design's limb preparation (cut, frame, landmarks).
  volume::LimbInputOptions lo;
  lo.cut_height_m = 130 * kMm;
  const auto model = volume::prepare_limb(
      volume::merge_shells(volume::generate_limb(volume::default_params(LimbType::Transtibial, 1))), {}, lo);
  std::vector<std::string> notes;
  const BrimLine kbm = make_brim(BrimTemplate::Kbm, model, {}, &notes);
  EXPECT_FALSE(notes.empty());
  EXPECT_LE(kbm.max_height(), model.cut_height_m - 5 * kMm + 1e-9) << kbm.max_height() / kMm;
}

TEST(BrimTemplate, transfemoral_templates_follow_ischium_and_trochanter) {
  // The generated thigh reaches 80-100 mm above the ischial tuberosity (buttock and groin).
  const auto& l = tf_limb();
  const double is = lm_h(l, "IS"), cut = l.cut_height_m;
  const double th_is = lm_theta(l, "IS"), th_al = lm_theta(l, "AL"), th_gt = lm_theta(l, "GT");
  ASSERT_GT(cut, is + 55 * kMm);
  std::vector<std::string> notes;
  const BrimLine quad = make_brim(BrimTemplate::Quad, LimbType::Transfemoral, l.landmarks, cut, {}, &notes);
  const BrimLine ics = make_brim(BrimTemplate::Ics, LimbType::Transfemoral, l.landmarks, cut, {}, &notes);
  // Quadrilateral: a level seat at IS from behind the tuberosity round to posterior, the anterior
  // wall 65 mm higher (clamped below the cut), lateral above medial.
  EXPECT_NEAR(quad.height(180 * kDeg), is, 1e-9);
  EXPECT_NEAR(quad.height(std::min(th_is + 25 * kDeg, 165 * kDeg)), is, 1e-9);
  EXPECT_GT(quad.height(0), is + 50 * kMm);
  EXPECT_GT(quad.height(th_gt), quad.height(90 * kDeg));
  // ICS: not flat (>= 40 mm around), highest postero-medially where it wraps the tuberosity, a
  // relief over the adductor longus, the lateral wall above the trochanter.
  EXPECT_GE(ics.max_height() - ics.min_height(), 40 * kMm);
  double th_max = 0, h_max = -1;
  for (int d = -180; d < 180; ++d)
    if (ics.height(d * kDeg) > h_max) h_max = ics.height(d * kDeg), th_max = d;
  EXPECT_GT(th_max, 90) << "highest at " << th_max << " deg";  // postero-medial
  EXPECT_LT(th_max, 180) << "highest at " << th_max << " deg";
  EXPECT_GT(ics.height(th_is), is + 25 * kMm);  // the tuberosity lies inside the containment
  EXPECT_LT(ics.height(th_al), is + 10 * kMm);  // the adductor longus relief
  EXPECT_GT(ics.height(th_gt), lm_h(l, "GT"));   // over the trochanter
  EXPECT_TRUE(notes.empty()) << notes.front();
  // A stump that ends too low: the key points are clamped below its cut, and each clamp is said.
  const BrimLine clamped =
      make_brim(BrimTemplate::Ics, LimbType::Transfemoral, l.landmarks, is + 20 * kMm, {}, &notes);
  EXPECT_LE(clamped.max_height(), is + 15 * kMm + 1e-4);
  ASSERT_FALSE(notes.empty());
  EXPECT_NE(notes.front().find("clamped"), std::string::npos) << notes.front();
  // The default brim follows the limb type.
  EXPECT_EQ(default_brim(LimbType::Transfemoral), BrimTemplate::Ics);
  EXPECT_EQ(default_brim(LimbType::Transtibial), BrimTemplate::Ptb);
}

TEST(BrimLine, key_points_can_be_moved_and_given_explicitly) {
  BrimLine b = brim_from_key_points({{"a", 0.0, 0.15}, {"m", 1.5, 0.17}, {"p", 3.1, 0.12}, {"l", -1.5, 0.17}});
  EXPECT_EQ(b.kind(), BrimTemplate::Custom);
  EXPECT_NEAR(b.height(1.5), 0.17, 1e-12);
  b.move_key_point(1, 1.4, 0.18);
  EXPECT_TRUE(b.is_edited());
  EXPECT_NEAR(b.height(1.4), 0.18, 1e-12);
  EXPECT_THROW(b.move_key_point(7, 0.0, 0.1), InvalidInputError);
  const std::string dup = message_of([&] { b.move_key_point(1, 0.0, 0.1); });  // onto key point 0's angle
  EXPECT_NE(dup.find("brim line:"), std::string::npos) << dup;
  EXPECT_NEAR(b.height(1.4), 0.18, 1e-12);  // unchanged after the error
  EXPECT_THROW(brim_from_key_points({{"a", 0.0, 0.1}, {"b", 1.0, 0.1}}), InvalidInputError);
}

TEST(BrimLine, raised_locally_where_lifted_and_unchanged_elsewhere) {
  const auto& l = tt_limb();
  const BrimLine b = make_brim(BrimTemplate::Ptb, LimbType::Transtibial, l.landmarks, l.cut_height_m);
  const double posterior = std::numbers::pi - 0.1, cap = b.max_height() + 50 * kMm;
  const BrimLine r = raise_brim(b, {{posterior, 4 * kMm}, {posterior + 0.05, 2 * kMm}, {1.0, -3 * kMm}}, 10 * kDeg, cap);
  EXPECT_EQ(r.kind(), b.kind());
  for (int k = -100; k <= 100; ++k) {  // within ±10° of the lift: raised by it (the larger of two)
    const double th = posterior + k * 0.1 * kDeg;
    EXPECT_NEAR(r.height(th) - b.height(th), 4 * kMm, 0.1 * kMm) << k;
  }
  for (int k = 0; k < 720; ++k) {
    const double th = -std::numbers::pi + k * 0.5 * kDeg;
    const double d = std::abs(std::remainder(th - posterior, 2 * std::numbers::pi));
    const double up = r.height(th) - b.height(th);
    EXPECT_GE(up, -0.1 * kMm) << th;          // never lower (the negative lift does nothing)
    EXPECT_LE(up, 4 * kMm + 0.1 * kMm) << th;
    if (d >= 23 * kDeg) {
      EXPECT_NEAR(up, 0.0, 0.1 * kMm) << th;  // beyond both easings: the brim as it was
    }
  }
  // Capped: never above max_height_m where it was below, never lowered where it was above.
  const double low_cap = b.height(posterior) + 1 * kMm;
  const BrimLine c = raise_brim(b, {{posterior, 4 * kMm}}, 10 * kDeg, low_cap);
  EXPECT_NEAR(c.height(posterior), low_cap, 0.1 * kMm);
  EXPECT_NEAR(c.height(0.0), b.height(0.0), 0.1 * kMm);  // the anterior brim, above the cap, stays
  // Nothing to lift: the same line, key points and all.
  EXPECT_EQ(raise_brim(b, {{0.0, 0.0}}, 10 * kDeg, cap).key_points().size(), b.key_points().size());
  EXPECT_THROW(raise_brim(b, {{std::nan(""), 1 * kMm}}, 10 * kDeg, cap), InvalidInputError);
  EXPECT_THROW(raise_brim(b, {{0.0, 1 * kMm}}, 0.0, cap), InvalidInputError);
}

TEST(BrimLine, an_eased_lift_holds_over_its_plateau_then_fades_as_cos2) {
  const double plateau = 10 * kDeg;
  const std::vector<BrimLift> lifts{{std::numbers::pi - 0.05, 4 * kMm}, {-std::numbers::pi + 0.05, 2 * kMm}, {1.0, -1}};
  EXPECT_DOUBLE_EQ(eased_lift(lifts, plateau, std::numbers::pi), 4 * kMm);  // across ±π: the larger
  EXPECT_DOUBLE_EQ(eased_lift(lifts, plateau, std::numbers::pi - 0.05 - plateau), 4 * kMm);
  // Half-way down the easing: cos²(π/4) = 1/2 of the lift (the other lift's plateau ends nearer).
  const double th = std::numbers::pi - 0.05 - 1.5 * plateau;
  EXPECT_NEAR(eased_lift(lifts, plateau, th), 2 * kMm, 1e-12);
  EXPECT_DOUBLE_EQ(eased_lift(lifts, plateau, 0.0), 0.0);  // far from both; the negative lift does nothing
  EXPECT_DOUBLE_EQ(eased_lift(lifts, plateau, 1.0), 0.0);
  EXPECT_DOUBLE_EQ(eased_lift({}, plateau, 1.0), 0.0);
}

TEST(BrimLine, above_brim_compares_h_with_the_curve_in_the_frame) {
  const auto& l = tt_limb();
  const BrimLine b = make_brim(BrimTemplate::Ptb, LimbType::Transtibial, l.landmarks, l.cut_height_m);
  const auto& f = l.frame;
  for (double th : {0.0, 1.0, 2.5, -2.0}) {
    const double h = b.height(th);
    EXPECT_TRUE(above_brim(b, f.from_cylindrical({0.05, th, h + 1e-4}), f));
    EXPECT_FALSE(above_brim(b, f.from_cylindrical({0.05, th, h - 1e-4}), f));
  }
  const auto flags = points_above_brim(b, {f.on_axis(0.01), f.on_axis(0.5)}, f);
  EXPECT_EQ(flags, (std::vector<char>{0, 1}));
}

TEST(ValidateBrim, accepts_templates_and_rejects_a_brim_above_the_skin_or_too_low) {
  const auto& l = tt_limb();
  const BrimLine b = make_brim(BrimTemplate::Ptb, LimbType::Transtibial, l.landmarks, l.cut_height_m);
  EXPECT_NO_THROW(validate_brim(b, l.skin, l.frame));
  BrimLine high = b;
  high.move_key_point(2, high.key_points()[2].theta, l.cut_height_m + 0.02);
  const std::string msg = message_of([&] { validate_brim(high, l.skin, l.frame); });
  EXPECT_NE(msg.find("key point 2 'medial wing (condyle)'"), std::string::npos) << msg;
  EXPECT_NE(msg.find("above the top of the skin"), std::string::npos) << msg;
  const BrimLine low = brim_from_key_points({{"", 0.0, 0.03}, {"", 2.0, 0.03}, {"", -2.0, 0.03}});
  const std::string lowmsg = message_of([&] { validate_brim(low, l.skin, l.frame); });
  EXPECT_NE(lowmsg.find("of the skin lies below the brim"), std::string::npos) << lowmsg;
  const BrimLine under = brim_from_key_points({{"x", 0.0, -0.01}, {"", 2.0, 0.1}, {"", -2.0, 0.1}});
  EXPECT_NE(message_of([&] { validate_brim(under, l.skin, l.frame); }).find("below the distal end"), std::string::npos);
}

}  // namespace
}  // namespace socketsmith::design
