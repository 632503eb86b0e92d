#pragma once
/// @file cube_study.h
/// The thesis's cube experiment as `socketsmith simulate cube` runs it (Figs. 28–30,
/// tissue/cube_experiment.h): the selected tissue model and the references drawn beside it —
/// MSS-CS with the recommended and the thesis's constants, MSS-CF, MSS — on one cube, and their
/// outputs: cube.csv (the selected model), cube_all.csv (every model, with its index), cube.svg
/// (the three panels) and summary.json. Here rather than in `tissue` because the plot is
/// `report`'s; the CLI only turns flags into the request and prints the selected model's errors.

#include <filesystem>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "socketsmith/core/progress.h"
#include "socketsmith/tissue/cube_experiment.h"

namespace socketsmith::pipeline {

/// A tissue model run in the study, with its label in the plot and the summary.
struct CubeStudyModel {
  std::string label;
  tissue::MassSpringOptions options;
};

/// The label of a model: its name, and for MSS-CS the name of its constants ("mss-cs (thesis)").
std::string cube_model_label(const tissue::MassSpringOptions& options, const std::string& constants);

/// The selected model, labelled with @p constants (a preset's name, or "custom" for constants set
/// one by one), then the references: MSS-CS with the recommended and the thesis's constants, MSS-CF
/// (with the selected model's target Poisson ratio) and MSS with the thesis's A — each label once.
std::vector<CubeStudyModel> cube_study_models(const tissue::MassSpringOptions& selected, const std::string& constants);

/// What to run: the cube, its lattice, the weights and the material shared by every model
/// (experiment.model is ignored), and the models, the selected one first.
struct CubeStudyRequest {
  tissue::CubeExperimentOptions experiment;
  std::vector<CubeStudyModel> models;
  ProgressCallback progress;  ///< each model's run from 0 to 1 in turn
};

/// A model's run in the study.
struct CubeStudyRun {
  std::string label;
  tissue::CubeExperimentResult result;
};

struct CubeStudy {
  std::vector<CubeStudyRun> runs;  ///< in the order of the request's models
  nlohmann::json summary;          ///< summary.json: "models" (each with its options, errors and rows), "selected" (the first), the cube, "outputs"
};

/// Runs every model of @p request (a reference that stops early is kept with a warning) and writes
/// cube.csv, cube_all.csv, cube.svg and summary.json into @p out (created; each file atomically).
/// @throws SolverError when the selected model does not converge (before the references run; @p out
///         is then created but empty); InvalidInputError without a model.
CubeStudy run_cube_study(const CubeStudyRequest& request, const std::filesystem::path& out);

}  // namespace socketsmith::pipeline
