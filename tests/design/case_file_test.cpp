// The case file: file units ↔ SI, round trip, and one-line errors for bad input.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>

#include "socketsmith/core/errors.h"
#include "socketsmith/core/units.h"
#include "socketsmith/design/case_file.h"

namespace socketsmith::design {
namespace {
using nlohmann::json;

json full_case() {
  return json::parse(R"({
    "socketsmith_case": 1,
    "limb": {"file": "scan.stl", "bones": "estimate", "units": "mm", "type": "transtibial", "side": "left",
             "anterior": [0, 1, 0], "cut_height_mm": 180},
    "patient": {"id": "P-7", "note": "a <note>", "body_mass_kg": 80, "prosthesis_mass_kg": 2.5, "friction": 0.4,
                "thresholds_kpa": {"MF": 50, "PT": 190, "FH": 45, "POP": 60, "AD": 98, "TC": 30}},
    "tissue": {"model": "mss-cf", "constants": "thesis", "youngs_kpa": 200, "density_kg_m3": 1000, "poisson": 0.47,
               "solve": "auto"},
    "mesh": {"target_nodes": 12000},
    "landmarks": {"PT": [1, 2, 3]},
    "design": {"optimise": false, "objective": "ratio", "model_pressure_limit": 0.3,
               "spots": [{"name": "PT", "type": "cos2", "amplitude_kpa": 30, "theta0_deg": 10, "r_theta_deg": 20,
                          "h0_mm": 120, "r_h_mm": 15, "max_amplitude_kpa": 50},
                         {"name": "band", "type": "sig2", "amplitude_kpa": 5, "theta1_deg": 150, "theta2_deg": -150,
                          "lambda_theta_per_deg": 0.5, "h1_mm": 20, "h2_mm": 90, "lambda_h_per_mm": 0.4,
                          "optimise_position": false}]},
    "brim": {"template": "kbm", "key_points": [{"theta_deg": 0, "h_mm": 150}, {"theta_deg": 90, "h_mm": 170},
                                               {"theta_deg": 180, "h_mm": 140, "label": "back"}]},
    "socket": {"thickness_mm": 4, "distal_pad": true, "distal_pad_diameter_mm": 30, "round_brim": false,
               "subdivisions": 1, "distal_thickness_mm": 7, "brim_thickness_mm": 3.5,
               "alignment": {"flexion_deg": 6, "adduction_deg": -2},
               "attachment": {"bolt": "M5", "hole_spacing_mm": 28, "platform_diameter_mm": 55,
                              "platform_thickness_mm": 9, "rotation_deg": 12, "offset_mm": [2, -1.5]}}
  })");
}

TEST(CaseFile, file_units_become_si) {
  const CaseFile c = parse_case(full_case(), "/cases");
  EXPECT_EQ(c.limb.file, "scan.stl");
  EXPECT_EQ(resolve(c, c.limb.file), std::filesystem::path("/cases/scan.stl"));
  EXPECT_EQ(resolve(c, "/abs/x.stl"), std::filesystem::path("/abs/x.stl"));
  EXPECT_EQ(*c.limb.side, geometry::Side::Left);
  EXPECT_NEAR(*c.limb.cut_height_m, 0.18, 1e-12);
  EXPECT_DOUBLE_EQ(c.patient.body_mass_kg, 80);
  EXPECT_DOUBLE_EQ(c.patient.friction, 0.4);
  EXPECT_NEAR(c.thresholds.at("PT"), 190e3, 1e-6);
  EXPECT_NEAR(c.thresholds.at("TC"), 30e3, 1e-6);
  EXPECT_NEAR(c.youngs_modulus_pa, 200e3, 1e-6);
  EXPECT_EQ(c.solve_mode, DesignSolveMode::Auto);
  ASSERT_TRUE(c.poisson_ratio.has_value());
  EXPECT_DOUBLE_EQ(*c.poisson_ratio, 0.47);
  EXPECT_EQ(c.target_nodes, 12000);
  EXPECT_NEAR(c.landmarks.at("PT").z(), 0.003, 1e-12);
  EXPECT_FALSE(c.optimise);
  EXPECT_EQ(c.objective, OptimizerOptions::Objective::Ratio);
  ASSERT_EQ(c.spots.size(), 2u);
  EXPECT_NEAR(c.spots[0].amplitude_pa, 30e3, 1e-6);
  EXPECT_NEAR(c.spots[0].theta0, 10 * units::deg, 1e-12);
  EXPECT_NEAR(c.spots[0].h0, 0.12, 1e-12);
  EXPECT_NEAR(c.spots[0].max_amplitude_pa, 50e3, 1e-6);
  EXPECT_EQ(c.spots[1].type, SpotType::Sig2);
  EXPECT_NEAR(c.spots[1].lambda_theta, 0.5 / units::deg, 1e-9);   // per degree → per radian
  EXPECT_NEAR(c.spots[1].lambda_h, 400.0, 1e-9);                   // per mm → per metre
  EXPECT_FALSE(c.spots[1].optimise_position);
  EXPECT_EQ(c.brim, BrimTemplate::Kbm);
  ASSERT_EQ(c.brim_key_points.size(), 3u);
  EXPECT_NEAR(c.brim_key_points[1].theta, 90 * units::deg, 1e-12);
  EXPECT_NEAR(c.brim_key_points[2].h, 0.14, 1e-12);
  EXPECT_EQ(c.brim_key_points[2].label, "back");
  EXPECT_NEAR(c.socket.thickness_m, 0.004, 1e-12);
  EXPECT_TRUE(c.socket.distal_pad);
  EXPECT_FALSE(c.socket.round_brim);
  EXPECT_NEAR(c.socket.distal_thickness_m, 0.007, 1e-12);
  EXPECT_NEAR(c.socket.brim_thickness_m, 0.0035, 1e-12);
  EXPECT_NEAR(c.socket.alignment.flexion_rad, 6 * units::deg, 1e-12);
  EXPECT_NEAR(c.socket.alignment.adduction_rad, -2 * units::deg, 1e-12);
  const SocketAttachment& a = c.socket.attachment;
  EXPECT_TRUE(a.enabled);
  EXPECT_EQ(a.bolt, "M5");
  EXPECT_NEAR(a.bolt_diameter_m, 0.005, 1e-12);
  EXPECT_NEAR(a.hole_diameter_m, 0.0055, 1e-12);  // ISO 273 medium clearance of M5
  EXPECT_NEAR(a.hole_spacing_m, 0.028, 1e-12);
  EXPECT_NEAR(a.platform_diameter_m, 0.055, 1e-12);
  EXPECT_NEAR(a.platform_thickness_m, 0.009, 1e-12);
  EXPECT_NEAR(a.rotation_rad, 12 * units::deg, 1e-12);
  EXPECT_NEAR(a.offset_anterior_m, 0.002, 1e-12);
  EXPECT_NEAR(a.offset_medial_m, -0.0015, 1e-12);
}

TEST(CaseFile, the_attachment_and_the_alignment_have_clinical_defaults) {
  const CaseFile none = parse_case(json::object());
  EXPECT_FALSE(none.socket.attachment.enabled);
  EXPECT_NEAR(none.socket.alignment.flexion_rad, 5 * units::deg, 1e-12);
  EXPECT_DOUBLE_EQ(none.socket.alignment.adduction_rad, 0.0);
  EXPECT_FALSE(case_to_json(none)["socket"].contains("attachment"));
  const CaseFile c = parse_case(json::parse(R"({"socket": {"attachment": {}}})"));
  const SocketAttachment& a = c.socket.attachment;
  EXPECT_TRUE(a.enabled);
  EXPECT_EQ(a.bolt, "M6");
  EXPECT_NEAR(a.hole_diameter_m, 0.0066, 1e-12);
  EXPECT_NEAR(a.hole_spacing_m, 0.030, 1e-12);
  EXPECT_NEAR(a.platform_diameter_m, 0.060, 1e-12);
  EXPECT_NEAR(a.platform_thickness_m, 0.010, 1e-12);
  EXPECT_FALSE(parse_case(json::parse(R"({"socket": {"attachment": {"enabled": false}}})")).socket.attachment.enabled);
}

TEST(CaseFile, round_trip_keeps_every_value) {
  const CaseFile a = parse_case(full_case(), "/cases");
  const CaseFile b = parse_case(case_to_json(a), "/cases");
  EXPECT_EQ(case_to_json(a), case_to_json(b));
  ASSERT_EQ(b.spots.size(), a.spots.size());
  for (size_t k = 0; k < a.spots.size(); ++k) {
    EXPECT_NEAR(b.spots[k].amplitude_pa, a.spots[k].amplitude_pa, 1e-9);
    EXPECT_NEAR(b.spots[k].theta1, a.spots[k].theta1, 1e-12);
    EXPECT_NEAR(b.spots[k].lambda_theta, a.spots[k].lambda_theta, 1e-9);
  }
  // Through a file, atomically written.
  const auto dir = std::filesystem::temp_directory_path() / "socketsmith_case_test";
  std::filesystem::create_directories(dir);
  write_case(dir / "case.json", a);
  const CaseFile c = read_case(dir / "case.json");
  EXPECT_EQ(case_to_json(c), case_to_json(a));
  EXPECT_EQ(c.folder, std::filesystem::absolute(dir));
}

// Lengths are read as mm × 1e-3 and written back as m / 1e-3, the inverse operation: 9 mm
// written as m × 1e3 came back as 9.000000000000002 and drifted with every save.
TEST(CaseFile, brim_key_points_and_landmarks_are_written_in_the_millimetres_they_were_read_in) {
  const nlohmann::json doc = nlohmann::json::parse(R"({"brim": {"key_points": [{"label": "PT", "theta_deg": 0, "h_mm": 9}]},
                                                       "landmarks": {"PT": [9, 0.3, 7.1]}})");
  const nlohmann::json out = case_to_json(parse_case(doc, "/cases"));
  EXPECT_EQ(out.at("brim").at("key_points").at(0).at("h_mm").get<double>(), 9.0);
  EXPECT_EQ(out.at("landmarks").at("PT"), nlohmann::json::parse("[9, 0.3, 7.1]"));
}

TEST(CaseFile, a_model_named_without_a_solve_gets_its_own) {
  // The lattices and fe collapse on the thin tissue over bone when solved nonlinearly
  // (docs/design.md): named alone they keep the linear solve; neo-Hookean is solved nonlinearly.
  EXPECT_EQ(parse_case(json{{"tissue", {{"model", "mss-cs"}}}}).solve_mode, DesignSolveMode::Linear);
  EXPECT_EQ(parse_case(json{{"tissue", {{"model", "fe"}}}}).solve_mode, DesignSolveMode::Linear);
  EXPECT_EQ(parse_case(json{{"tissue", {{"model", "neo-hookean"}}}}).solve_mode, DesignSolveMode::Nonlinear);
  EXPECT_EQ(parse_case(json{{"tissue", {{"model", "mss-cs"}, {"solve", "nonlinear"}}}}).solve_mode,
            DesignSolveMode::Nonlinear);
  const CaseFile stiffer = parse_case(json{{"tissue", {{"youngs_kpa", 200}}}});
  EXPECT_EQ(stiffer.model, "neo-hookean");
  EXPECT_EQ(stiffer.solve_mode, DesignSolveMode::Nonlinear);
  // What is written reads back the same, and a written document whose model is then edited (a
  // replay case, a Python dict) gets the new model's solve, as a hand-written one does.
  const CaseFile lattice = parse_case(json{{"tissue", {{"model", "mss-cs"}}}});
  EXPECT_EQ(parse_case(case_to_json(lattice)).solve_mode, DesignSolveMode::Linear);
  const CaseFile lattice_nonlinear = parse_case(json{{"tissue", {{"model", "mss-cs"}, {"solve", "auto"}}}});
  EXPECT_EQ(parse_case(case_to_json(lattice_nonlinear)).solve_mode, DesignSolveMode::Auto);
  json edited = case_to_json(CaseFile{});
  edited["tissue"]["model"] = "fe";
  EXPECT_EQ(parse_case(edited).solve_mode, DesignSolveMode::Linear);
}

TEST(CaseFile, an_empty_document_is_the_default_case) {
  const CaseFile c = parse_case(json::object());
  EXPECT_TRUE(c.limb.file.empty());  // the generated sample
  EXPECT_TRUE(c.spots.empty());      // the default layout
  EXPECT_TRUE(c.thresholds.empty()); // Table 7
  EXPECT_FALSE(c.brim.has_value());  // the limb type's default (PTB, ICS)
  EXPECT_EQ(c.limb.scale, 1.0);
  EXPECT_FALSE(c.limb.axis.has_value());
  EXPECT_FALSE(c.limb.force_size);
  EXPECT_EQ(c.model, "neo-hookean");  // chosen by measurement (docs/design.md)
  EXPECT_EQ(c.solve_mode, DesignSolveMode::Nonlinear);
  EXPECT_NEAR(c.socket.thickness_m, 0.005, 1e-12);
  EXPECT_EQ(case_to_json(c)["design"]["spots"], "default");
}

// The brim's flare: 5 mm on a transtibial limb, none on a transfemoral one (its ischial seat is its
// brim); a given value is kept, in mm in the file, and a default is not written.
TEST(CaseFile, the_closed_loops_drag_band_is_on_unless_turned_off) {
  const CaseFile d = parse_case(json::parse("{}"));
  EXPECT_TRUE(d.closed_loop_drag_band);
  EXPECT_FALSE(case_to_json(d)["design"].contains("closed_loop_drag_band"));
  const CaseFile off = parse_case(json::parse(R"({"design": {"closed_loop_drag_band": false}})"));
  EXPECT_FALSE(off.closed_loop_drag_band);
  EXPECT_FALSE(parse_case(case_to_json(off)).closed_loop_drag_band);
  EXPECT_THROW(parse_case(json::parse(R"({"design": {"closed_loop_drag_band": 2}})")), Error);
}

TEST(CaseFile, the_brim_flare_defaults_by_level_and_a_given_value_is_kept) {
  const CaseFile tt = parse_case(json::object());
  EXPECT_DOUBLE_EQ(brim_flare_m(tt), 0.005);
  EXPECT_FALSE(case_to_json(tt)["design"].contains("brim_flare_mm"));
  const CaseFile tf = parse_case(json::parse(R"({"limb": {"type": "transfemoral"}})"));
  EXPECT_DOUBLE_EQ(brim_flare_m(tf), 0.0);
  const CaseFile given = parse_case(json::parse(R"({"design": {"brim_flare_mm": 0}})"));
  EXPECT_DOUBLE_EQ(brim_flare_m(given), 0.0);
  const CaseFile ten = parse_case(json::parse(R"({"limb": {"type": "transfemoral"}, "design": {"brim_flare_mm": 10}})"));
  EXPECT_DOUBLE_EQ(brim_flare_m(ten), 0.010);
  EXPECT_DOUBLE_EQ(case_to_json(ten)["design"]["brim_flare_mm"].get<double>(), 10.0);
  EXPECT_THROW(parse_case(json::parse(R"({"design": {"brim_flare_mm": -1}})")), Error);
}

TEST(CaseFile, the_loop_is_closed_by_default_on_both_levels_and_a_given_value_is_kept) {
  const CaseFile tt = parse_case(json::object());
  EXPECT_FALSE(tt.closed_loop.has_value());
  EXPECT_TRUE(closes_loop(tt));  // docs/design.md, "Closed loop": the default socket delivers its design
  EXPECT_FALSE(case_to_json(tt)["design"].contains("closed_loop"));  // a replay keeps the default
  const CaseFile tf = parse_case(json::parse(R"({"limb": {"type": "transfemoral"}})"));
  EXPECT_TRUE(closes_loop(tf));  // since 2026-11-30: 11 transfemoral limbs measured (docs/design.md)
  for (const bool given : {false, true}) {
    json j = json::object();
    j["limb"]["type"] = given ? "transfemoral" : "transtibial";
    j["design"]["closed_loop"] = given;
    const CaseFile c = parse_case(j);
    EXPECT_EQ(closes_loop(c), given);
    const CaseFile again = parse_case(case_to_json(c));
    ASSERT_TRUE(again.closed_loop.has_value());
    EXPECT_EQ(*again.closed_loop, given);
  }
  EXPECT_THROW(parse_case(json::parse(R"({"design": {"closed_loop": "yes"}})")), InvalidInputError);
}

TEST(CaseFile, following_the_template_and_the_uniform_objective_are_read_and_kept) {
  EXPECT_TRUE(parse_case(json::object()).follow_template);  // the default: the optimiser aims at the template
  const CaseFile c = parse_case(json::parse(R"({"design": {"follow_template": false, "objective": "uniform"}})"));
  EXPECT_FALSE(c.follow_template);
  EXPECT_EQ(c.objective, OptimizerOptions::Objective::Uniform);
  const CaseFile again = parse_case(case_to_json(c));
  EXPECT_FALSE(again.follow_template);
  EXPECT_EQ(again.objective, OptimizerOptions::Objective::Uniform);
  EXPECT_THROW(parse_case(json::parse(R"({"design": {"follow_template": "yes"}})")), InvalidInputError);
  EXPECT_THROW(parse_case(json::parse(R"({"design": {"objective": "even"}})")), InvalidInputError);
}

TEST(CaseFile, a_seed_built_in_code_is_a_seed_as_one_read_from_a_file) {
  // nlohmann::json holds a positive int literal as a signed integer, a parsed one as unsigned.
  EXPECT_EQ(parse_case(json{{"limb", {{"generate_seed", 3}}}}).limb.generate_seed, 3u);
  EXPECT_EQ(parse_case(json::parse(R"({"limb": {"generate_seed": 3}})")).limb.generate_seed, 3u);
  EXPECT_THROW(parse_case(json{{"limb", {{"generate_seed", -3}}}}), InvalidInputError);
}

void expect_error(const std::string& text, const std::string& needle) {
  try {
    parse_case(json::parse(text));
    ADD_FAILURE() << "no error for " << text;
  } catch (const InvalidInputError& e) {
    EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what();
    EXPECT_EQ(std::string(e.what()).find('\n'), std::string::npos) << "one line: " << e.what();
  }
}

TEST(CaseFile, bad_input_is_one_line_naming_the_key) {
  expect_error(R"({"patient": {"body_mas_kg": 70}})", "unknown key 'body_mas_kg' in 'patient'");
  expect_error(R"({"pateint": {}})", "unknown key 'pateint'");
  // A key with a line break (found by fuzzing): the message stays one line, the break shown escaped.
  expect_error(R"({"patient": {"a\nb": 1}})", "unknown key 'a\\nb' in 'patient'");
  expect_error(R"({"patient": {"body_mass_kg": -70}})", "body mass must be positive");
  expect_error(R"({"patient": {"body_mass_kg": -70}})", "patient.body_mass_kg = -70 kg is outside (0, 400) kg");
  expect_error(R"({"patient": {"body_mass_kg": "70"}})", "must be a number");
  expect_error(R"({"patient": {"body_mass_kg": 40, "prosthesis_mass_kg": 45}})", "is not below the body mass");
  expect_error(R"({"patient": {"prosthesis_mass_kg": 90}})", "patient.prosthesis_mass_kg = 90 kg is outside [0, 50] kg");
  expect_error(R"({"patient": {"friction": 3}})", "case file: patient.friction = 3 is outside [0, 2]");
  expect_error(R"({"patient": {"thresholds_kpa": {"PT": "high"}}})", "must be a number in kPa");
  expect_error(R"({"socket": {"thickness_mm": 0}})", "thickness_mm = 0 mm");
  expect_error(R"({"socket": {"thickness_mm": -5}})", "thickness_mm = -5 mm");
  expect_error(R"({"tissue": {"youngs_kpa": -1}})", "youngs_kpa");
  expect_error(R"({"mesh": {"target_nodes": 2500.5}})", "mesh.target_nodes = 2500.5 is not a whole number");
  expect_error(R"({"socket": {"subdivisions": 9}})", "socket.subdivisions = 9 is outside [0, 3]");
  expect_error(R"({"design": {"model_pressure_limit": -1}})", "design.model_pressure_limit = -1 is outside [0, 5]");
  expect_error(R"({"design": {"time_limit_s": 0}})", "design.time_limit_s = 0 s is outside (0, 86400] s");
  expect_error(R"({"limb": {"bones": ""}})", "limb.bones is empty");
  expect_error(R"({"patient": {"thresholds_kpa": {"PT": -5}}})", "patient.thresholds_kpa.PT = -5 kPa is outside");
  expect_error(R"({"tissue": {"model": "fem"}})", "tissue.model 'fem' is not known");
  expect_error(R"({"tissue": {"solve": "fast"}})", "design solve mode 'fast' is not known");
  expect_error(R"({"tissue": {"model": "mss-cs", "poisson": 0.45}})", "tissue.model 'mss-cs' has no Poisson ratio of its own");
  EXPECT_DOUBLE_EQ(*parse_case(json::parse(R"({"tissue": {"poisson": 0.47}})")).poisson_ratio, 0.47);  // the default model's
  expect_error(R"({"tissue": {"model": "fe", "poisson": 0.5}})", "tissue.poisson = 0.5 is outside [0, 0.5)");
  expect_error(R"({"tissue": {"model": "neo-hookean", "poisson": 0.5}})", "tissue.poisson = 0.5 is outside [0, 0.5)");
  expect_error(R"({"tissue": {"model": "mss-cf", "poisson": 0.2}})", "tissue.poisson = 0.2 is outside [0.25, 0.5)");
  expect_error(R"({"tissue": {"model": "mss-cs", "element": "fbar"}})", "tissue.element 'fbar' is for the neo-hookean model");
  expect_error(R"({"tissue": {"element": "c3d8r"}})", "unknown element formulation 'c3d8r'");
  {  // tissue.element: fbar read, written and read back; c3d8 (the default) not written
    const CaseFile f = parse_case(json::parse(R"({"tissue": {"element": "fbar"}})"));
    EXPECT_EQ(f.element, tissue::HexFormulation::FBar);
    EXPECT_EQ(case_to_json(f)["tissue"]["element"], "fbar");
    EXPECT_EQ(parse_case(case_to_json(f)).element, tissue::HexFormulation::FBar);
    EXPECT_FALSE(case_to_json(parse_case(json::parse("{}")))["tissue"].contains("element"));
  }
  expect_error(R"({"mesh": {"target_nodes": 10}})", "target_nodes = 10");
  expect_error(R"({"limb": {"units": "inch"}})", "inch");
  expect_error(R"({"limb": {"type": "banana"}})", "banana");
  expect_error(R"({"limb": {"anterior": [0, 0]}})", "limb.anterior");
  expect_error(R"({"brim": {"template": "bucket"}})", "bucket");
  expect_error(R"({"design": {"spots": [{"type": "cos2", "amplitude_kpa": -3}]}})", "negative");
  expect_error(R"({"design": {"spots": [{"amplitude_kpa": 3}]}})", "has no 'type'");
  expect_error(R"({"design": {"spots": [{"type": "blob"}]}})", "spot type 'blob' is not known");
  expect_error(R"({"design": {"spots": [{"type": "cos2", "h0": 3}]}})", "unknown key 'h0'");
  expect_error(R"({"design": {"objective": "cheap"}})", "design.objective 'cheap'");
  expect_error(R"({"socketsmith_case": 2})", "version 2 is not supported");
  expect_error(R"({"socket": {"attachment": {"bolt": "M7"}}})", "bolt 'M7' is not known");
  expect_error(R"({"socket": {"attachment": {"hole_diameter_mm": 5}}})", "narrower than the M6 bolt");
  expect_error(R"({"socket": {"attachment": {"hole_spacing_mm": 0}}})", "socket.attachment.hole_spacing_mm = 0 mm is outside (0, 150] mm");
  expect_error(R"({"socket": {"attachment": {"offset_mm": [30, 0]}}})", "socket.attachment.offset_mm[0] (anterior) = 30 mm is outside [-20, 20] mm");
  expect_error(R"({"socket": {"attachment": {"offset_mm": 3}}})", "offset_mm must be [anterior, medial]");
  expect_error(R"({"socket": {"attachment": {"hole_count": 3}}})", "unknown key 'hole_count' in 'socket.attachment'");
  expect_error(R"({"socket": {"alignment": {"flexion_deg": 45}}})", "socket.alignment.flexion_deg = 45 deg is outside [-30, 30] deg");
  expect_error(R"({"socket": {"attachment": {"offset_mm": [0, -21]}}})", "offset_mm[1] (medial) = -21 mm is outside");
  expect_error(R"({"design": {"closed_loop_donnings": 0}})", "design.closed_loop_donnings = 0 is outside [1, 20]");
  expect_error(R"({"design": {"closed_loop_donnings": 2.5}})", "design.closed_loop_donnings = 2.5 is not a whole number");
  expect_error(R"({"socket": {"alignment": {"abduction_deg": 3}}})", "unknown key 'abduction_deg'");
  expect_error(R"({"socket": {"distal_thickness_mm": 0.2}})", "socket.distal_thickness_mm = 0.2 mm is outside [1, 50] mm");
}

// Values that were silently replaced or accepted, each now one line naming the key and the range.
TEST(CaseFile, nothing_is_silently_replaced_by_a_default) {
  // "file": "" designed the generated sample limb; "spots": [] the default 32 spots.
  expect_error(R"({"limb": {"file": ""}})", "case file: limb.file is empty: give the scan's path");
  expect_error(R"({"design": {"spots": []}})", "case file: design.spots is an empty list");
  // No upper bound let a 155 N socket pass a 343 N target with tolerances of 1 (100 %).
  expect_error(R"({"patient": {"force_tolerance": 1}})", "case file: patient.force_tolerance = 1 is outside (0, 0.1]");
  expect_error(R"({"patient": {"torque_tolerance": 1}})", "case file: patient.torque_tolerance = 1 is outside (0, 0.1]");
  // 0 < E <= 5 kPa was accepted and ended in NaN; E = 0 was refused with another range than checked.
  expect_error(R"({"tissue": {"youngs_kpa": 5}})", "case file: tissue.youngs_kpa = 5 kPa is outside [10, 10000] kPa");
  expect_error(R"({"tissue": {"youngs_kpa": 0}})", "case file: tissue.youngs_kpa = 0 kPa is outside [10, 10000] kPa");
  // 1e20 nodes was reported as -2147483648 (the int overflowed before the check).
  expect_error(R"({"mesh": {"target_nodes": 1e20}})", "case file: mesh.target_nodes = 1e+20 is outside [200, 200000]");
  // Accepted values stay accepted.
  EXPECT_NO_THROW(parse_case(json::parse(R"({"patient": {"force_tolerance": 0.1}, "tissue": {"youngs_kpa": 10}})")));
  EXPECT_DOUBLE_EQ(parse_case(json::parse(R"({"design": {"time_limit_s": 30}})")).time_limit_s, 30.0);
}

TEST(CaseFile, a_number_too_large_for_a_double_is_one_line_naming_the_key) {
  // The GUI aborted (terminate: number overflow parsing '1e400') and the CLI exited 70.
  const auto p = std::filesystem::temp_directory_path() / "socketsmith_overflow_case.json";
  std::ofstream(p) << R"({"patient": {"body_mass_kg": 1e400}})";
  try {
    read_case(p);
    ADD_FAILURE() << "no error";
  } catch (const InvalidInputError& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("the number 1e400 at 'patient.body_mass_kg' is out of range"), std::string::npos) << m;
    EXPECT_EQ(m.find('\n'), std::string::npos) << m;
  }
  std::filesystem::remove(p);
}

TEST(CaseFile, limb_scale_axis_and_size_override_round_trip_and_are_checked) {
  const CaseFile c = parse_case(json::parse(
      R"({"limb": {"file": "tf.stl", "units": "m", "scale": 0.45, "axis": [0, 0, 2], "force_size": true,
                   "type": "transfemoral"},
          "design": {"ischial_share_min": 0.2}})"));
  EXPECT_DOUBLE_EQ(c.limb.scale, 0.45);
  ASSERT_TRUE(c.limb.axis.has_value());
  EXPECT_EQ(*c.limb.axis, Eigen::Vector3d(0, 0, 2));
  EXPECT_TRUE(c.limb.force_size);
  ASSERT_TRUE(c.ischial_share_min.has_value());
  EXPECT_DOUBLE_EQ(*c.ischial_share_min, 0.2);
  EXPECT_FALSE(c.brim.has_value());
  const CaseFile d = parse_case(case_to_json(c));
  EXPECT_EQ(case_to_json(d), case_to_json(c));
  EXPECT_DOUBLE_EQ(d.limb.scale, 0.45);
  EXPECT_FALSE(d.brim.has_value());  // still the limb type's default
  expect_error(R"({"limb": {"scale": -1}})", "limb.scale = -1 is outside (0, 10000]");
  expect_error(R"({"limb": {"axis": [0, 0, 0]}})", "'limb.axis' is the zero vector");
  expect_error(R"({"design": {"ischial_share_min": 1.5}})", "design.ischial_share_min = 1.5 is outside");
}

// The command line's --axis / --anterior and the case file's limb.axis / limb.anterior go through
// one check: the same values refused in the same words, the flag named.
TEST(CaseFile, limb_directions_from_the_command_line_are_checked_like_the_case_file) {
  EXPECT_EQ(parse_limb_direction("0,0,2", LimbDirection::Axis, "design --axis"), Eigen::Vector3d(0, 0, 2));
  EXPECT_EQ(parse_limb_direction(" 0.5, -1 ,1e-3 ", LimbDirection::Anterior, "design --anterior"),
            Eigen::Vector3d(0.5, -1, 1e-3));
  const auto message = [](const std::string& text, LimbDirection which) {
    try {
      parse_limb_direction(text, which, "design --axis");
    } catch (const InvalidInputError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_NE(message("0,0", LimbDirection::Axis).find("design --axis '0,0' is not a direction x,y,z (the long axis"),
            std::string::npos);
  EXPECT_NE(message("0,0,1,4", LimbDirection::Axis).find("is not a direction x,y,z"), std::string::npos);
  EXPECT_NE(message("a,b,c", LimbDirection::Axis).find("is not a direction x,y,z"), std::string::npos);
  EXPECT_NE(message("nan,0,1", LimbDirection::Axis).find("is not a direction"), std::string::npos);
  EXPECT_NE(message("1e400,0,1", LimbDirection::Axis).find("is not a direction"), std::string::npos);
  EXPECT_NE(message("0,0,0", LimbDirection::Axis).find("design --axis '0,0,0' is the zero vector (give the long axis"),
            std::string::npos);
  EXPECT_NE(message("0,0,0", LimbDirection::Anterior).find("is the zero vector (give the front of the limb"),
            std::string::npos);
  // The case file's words are the same check's.
  expect_error(R"({"limb": {"anterior": [0, 0, 0]}})", "case file: 'limb.anterior' is the zero vector (give the front");
  EXPECT_THROW(check_limb_direction(Eigen::Vector3d(0, std::nan(""), 1), LimbDirection::Axis, "x"), InvalidInputError);
}

TEST(CaseFile, files_that_are_missing_or_not_json) {
  EXPECT_THROW(read_case("/no/such/case.json"), IoError);
  const auto p = std::filesystem::temp_directory_path() / "socketsmith_not_json.json";
  std::ofstream(p) << "{\"patient\": ";
  try {
    read_case(p);
    ADD_FAILURE() << "no error";
  } catch (const InvalidInputError& e) {
    EXPECT_NE(std::string(e.what()).find("is not valid JSON"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace socketsmith::design
