// The cube study of `simulate cube` as a library call: the references beside the selected model,
// each label once, and the files and summary of a tiny run — the keys and values the CLI's
// summary.json and --json print.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "socketsmith/core/errors.h"
#include "socketsmith/pipeline/cube_study.h"
#include "socketsmith/report/csv.h"

namespace socketsmith::pipeline {
namespace {

namespace fs = std::filesystem;

std::vector<std::string> labels(const std::vector<CubeStudyModel>& models) {
  std::vector<std::string> out;
  for (const auto& m : models) out.push_back(m.label);
  return out;
}

tissue::MassSpringOptions mss_cs(const std::string& preset) {
  tissue::MassSpringOptions o;
  o.kind = tissue::TissueModelKind::MssCs;
  o.corrective = tissue::CorrectiveSpringConstants::preset(preset);
  return o;
}

/// A 1-element cube under three weights up to 10 N, in a fresh folder.
CubeStudyRequest tiny_request(const tissue::MassSpringOptions& selected, const std::string& constants) {
  CubeStudyRequest q;
  q.experiment.divisions = 1;
  q.experiment.num_weights = 3;
  q.experiment.max_weight_n = 10.0;
  q.models = cube_study_models(selected, constants);
  return q;
}

fs::path fresh_dir(const std::string& name) {
  const fs::path dir = fs::temp_directory_path() / name;
  fs::remove_all(dir);
  return dir;
}

TEST(CubeStudy, the_selected_model_comes_first_and_every_reference_once) {
  EXPECT_EQ(labels(cube_study_models(mss_cs("cube-targets"), "cube-targets")),
            (std::vector<std::string>{"mss-cs (cube-targets)", "mss-cs (recommended)", "mss-cs (thesis)", "mss-cf", "mss"}));
  EXPECT_EQ(labels(cube_study_models(mss_cs("thesis"), "thesis")),
            (std::vector<std::string>{"mss-cs (thesis)", "mss-cs (recommended)", "mss-cf", "mss"}));
  tissue::MassSpringOptions nh;
  nh.kind = tissue::TissueModelKind::NeoHookean;
  nh.cf_poisson_ratio = 0.45;
  const auto models = cube_study_models(nh, "cube-targets");
  EXPECT_EQ(labels(models), (std::vector<std::string>{"neo-hookean", "mss-cs (recommended)", "mss-cs (thesis)", "mss-cf", "mss"}));
  EXPECT_EQ(models[3].options.cf_poisson_ratio, 0.45) << "MSS-CF takes the selected model's target Poisson ratio";
  EXPECT_EQ(cube_model_label(mss_cs("thesis"), "custom"), "mss-cs (custom)");
}

TEST(CubeStudy, a_tiny_run_writes_its_files_and_a_summary_of_every_model) {
  const fs::path out = fresh_dir("socketsmith_cube_study_test");
  const CubeStudy study = run_cube_study(tiny_request(mss_cs("cube-targets"), "cube-targets"), out);
  ASSERT_EQ(study.runs.size(), 5u);
  for (const char* name : {"cube.csv", "cube_all.csv", "cube.svg", "summary.json"})
    EXPECT_TRUE(fs::exists(out / name)) << name;

  std::ifstream in(out / "summary.json");
  const nlohmann::json j = nlohmann::json::parse(in);
  EXPECT_EQ(j, study.summary);
  EXPECT_EQ(j["command"], "socketsmith simulate cube");
  EXPECT_EQ(j["divisions"], 1);
  EXPECT_EQ(j["nodes"], 8);
  EXPECT_EQ(j["elements"], 1);
  EXPECT_DOUBLE_EQ(j["edge_m"].get<double>(), 0.05);
  EXPECT_EQ(j["outputs"].size(), 4u);
  ASSERT_EQ(j["models"].size(), 5u);
  EXPECT_EQ(j["selected"], j["models"][0]);
  const nlohmann::json& m = j["selected"];
  EXPECT_EQ(m["label"], "mss-cs (cube-targets)");
  EXPECT_EQ(m["converged"], true);
  EXPECT_EQ(m["options"]["model"], "mss-cs");
  EXPECT_TRUE(m["options"].contains("corrective"));
  for (const char* key : {"max_displacement_error_to_60pct", "max_volume_error_to_40pct", "unstable_before_60pct",
                          "max_displacement_error_vs_own_energy", "max_volume_error_vs_own_energy", "wall_s", "message"})
    EXPECT_TRUE(m.contains(key)) << key;
  EXPECT_TRUE(m["max_displacement_error_vs_own_energy"].is_null()) << "a lattice has no analytic state of its own";
  ASSERT_EQ(m["rows"].size(), 3u);
  // The weights from 0 to the heaviest, and the analytic pressure W / A of a 50 mm cube.
  EXPECT_EQ(m["rows"][0]["weight_n"].get<double>(), 0.0);
  EXPECT_DOUBLE_EQ(m["rows"][2]["weight_n"].get<double>(), 10.0);
  EXPECT_NEAR(m["rows"][2]["top_pressure_analytic_pa"].get<double>(), 10.0 / (0.05 * 0.05), 1e-6);
  EXPECT_NEAR(m["rows"][2]["top_pressure_pa"].get<double>(), 10.0 / (0.05 * 0.05), 1.0) << "the box rests on the top";
  EXPECT_LT(m["rows"][2]["displacement_ratio"].get<double>(), 0.2);
  EXPECT_GT(m["rows"][2]["displacement_ratio"].get<double>(), 0.0);

  // cube.csv: the selected model's rows; cube_all.csv: every model's, after its index.
  const auto selected = report::read_csv(out / "cube.csv");
  EXPECT_EQ(selected.header.front(), "weight_n");
  EXPECT_EQ(selected.rows.size(), 3u);
  const auto all = report::read_csv(out / "cube_all.csv");
  EXPECT_EQ(all.header.front(), "model_index");
  ASSERT_EQ(all.rows.size(), 15u);
  EXPECT_EQ(all.rows.back().front(), 4.0);
  EXPECT_EQ(all.rows.front()[1], 0.0);
}

TEST(CubeStudy, a_selected_model_that_does_not_converge_is_a_solver_error_before_any_file) {
  tissue::MassSpringOptions fe;
  fe.kind = tissue::TissueModelKind::StVenantKirchhoff;
  CubeStudyRequest q = tiny_request(fe, "cube-targets");
  q.experiment.divisions = 2;
  q.experiment.max_weight_n = 2000.0;  // beyond the St Venant-Kirchhoff law's limit point
  const fs::path out = fresh_dir("socketsmith_cube_study_unstable");
  try {
    run_cube_study(q, out);
    FAIL() << "expected a SolverError";
  } catch (const SolverError& e) {
    EXPECT_NE(std::string(e.what()).find("simulate cube: "), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("try --divisions 4 or a smaller --max-weight"), std::string::npos) << e.what();
  }
  EXPECT_TRUE(fs::is_directory(out));
  EXPECT_TRUE(fs::is_empty(out));
}

TEST(CubeStudy, a_request_without_a_model_is_refused) {
  EXPECT_THROW(run_cube_study(CubeStudyRequest{}, fresh_dir("socketsmith_cube_study_empty")), InvalidInputError);
}

}  // namespace
}  // namespace socketsmith::pipeline
