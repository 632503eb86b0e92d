// `socketsmith scan ...`: the subcommands and their flags; the runs are in cmd_scan_recordings.cpp
// (simulate, reconstruct, calibrate, register) and cmd_scan_experiments.cpp (experiment ...).
#include <memory>
#include <string>

#include "cli_common.h"
#include "scan_cli.h"

namespace socketsmith::cli {
using namespace scan_cli;

namespace {

/// scan simulate: a scene ray-cast from a simulated rig into a recording folder.
void add_simulate_command(CLI::App* scan_cmd) {
  auto sf = std::make_shared<SimulateFlags>();
  auto* sim = scan_cmd->add_subcommand("simulate", "ray-cast a scene from a simulated Kinect v2 rig into a recording folder");
  sim->add_option("--mesh", sf->mesh, "scene mesh (STL/OBJ/PLY/AOP), centred on the rig");
  sim->add_option("--units", sf->units, "units of --mesh: mm | m (default: guessed)");
  sim->add_option("--cylinder-mm", sf->cylinder_mm, "scene: a cylinder of this diameter [mm] (thesis: 100, 160, 210)");
  sim->add_option("--cylinder-height-mm", sf->cylinder_height_mm, "height of the cylinder [mm] (default 400)");
  sim->add_flag("--box", sf->box, "scene: the 300 x 300 x 700 mm calibration box with a chessboard on each side");
  sim->add_option("--box-yaw-deg", sf->box_yaw_deg,
                  "turn of the box about the vertical [deg] (default 45: each board faces two neighbouring sensors, "
                  "as registration needs)");
  sim->add_flag("--chessboard", sf->chessboard,
                "a calibration session: each sensor sees the chessboard (9 x 6 inner corners, 60 mm) in a random pose "
                "per frame (use --frames, thesis ~50)");
  sim->add_option("--frames-per-pose", sf->frames_per_pose,
                  "--chessboard: frames recorded of each board pose (independent noise; --frames poses x this many "
                  "frames, 1 to 30, default 1); scan calibrate fuses them");
  sim->add_option("--min-distance-mm", sf->min_distance_mm, "--chessboard: nearest board distance [mm] (default 550)");
  sim->add_option("--max-distance-mm", sf->max_distance_mm, "--chessboard: farthest board distance [mm] (default 1000)");
  sim->add_option("--sensors", sf->sensors, "number of sensors on the ring (default 4)");
  sim->add_option("--radius-mm", sf->radius_mm, "ring radius [mm] (default 750, as the thesis)");
  sim->add_option("--height-mm", sf->height_mm, "sensor height above the scene centre [mm] (default 0)");
  add_simulated_error_flags(*sim, sf->seed, sf->noise_scale, sf->systematic_scale, sf->frames);
  sim->add_option("--calibration", sf->calibration,
                  "iai_kinect2 calibration: a folder of <serial> folders (one per sensor), a <serial> folder or a "
                  "calib_ir.yaml (default: typical Kinect v2 intrinsics)");
  sim->add_option("--out", sf->out, "recording folder to write")->required();
  sim->add_flag("--json", sf->json, "print a JSON summary on stdout");
  sim->callback([sf] { run_simulate(*sf); });
}

/// scan reconstruct: a recording folder (or loose depth frames) to a limb surface.
void add_reconstruct_command(CLI::App* scan_cmd) {
  auto rf = std::make_shared<ReconstructFlags>();
  auto* rec = scan_cmd->add_subcommand("reconstruct", "reconstruct a watertight limb surface from a recording folder");
  rec->add_option("recording", rf->recording, "recording folder (rig.json + one folder per sensor)");
  rec->add_option("--frame", rf->frames,
                  "instead of a recording: a 16-bit depth PNG of one static camera (repeat for a temporal median); "
                  "needs --intrinsics");
  rec->add_option("--intrinsics", rf->intrinsics,
                  "intrinsics of --frame: intrinsics.json, an Open3D camera json or an iai_kinect2 calib_ir.yaml");
  rec->add_option("--depth-scale", rf->depth_scale,
                  "metres per raw unit of --frame (default 0.001 = mm; TUM: 0.0002)");
  rec->add_option("--max-depth-m", rf->max_depth_m, "readings farther than this are ignored [m] (default 4.5)");
  rec->add_option("--rig", rf->rig, "rig file of 'scan register': replaces the sensor poses of rig.json (by name)");
  rec->add_option("--out", rf->out, "output surface: .stl, .obj, .ply or .aop, in mm")->required();
  auto* open = rec->add_flag("--open", rf->open, "leave the proximal cut open (one boundary loop)");
  auto* closed = rec->add_flag("--closed", rf->closed, "cap the proximal cut with a plane (default)");
  open->excludes(closed);
  rec->add_flag("--no-cut", rf->no_cut, "keep the whole Poisson surface (no proximal cut)");
  rec->add_option("--compensation", rf->compensation,
                  "learned error model (scan calibrate --out): applied to every sensor it names (overrides rig.json)");
  rec->add_option("--fusion", rf->fusion,
                  "per-pixel fusion of a sensor's several frames: median (default) | trimmed-mean (mean of the middle "
                  "half, kept at 0.1 mm)");
  rec->add_option("--upsample", rf->upsample, "bilinear up-sampling of the depth frames, 1 to 8 (default 1)");
  add_surface_flags(*rec, rf->grid_mm, rf->facet_mm, rf->smooth);
  rec->add_flag("--json", rf->json, "print a JSON summary on stdout");
  rec->callback([rf] { run_reconstruct(*rf); });
}

/// scan register: the rig's poses from a recording of the chessboard box.
void add_register_command(CLI::App* scan_cmd) {
  auto gf = std::make_shared<RegisterFlags>();
  auto* regc = scan_cmd->add_subcommand(
      "register", "register the sensors of a rig from a recording of the chessboard box (multi-set, thesis Table 2)");
  regc->add_option("recording", gf->recording, "recording of the registration box (IR + depth frames, rig.json with "
                                               "the hand-measured poses and \"chessboard\")")->required();
  regc->add_option("--out", gf->out, "rig file to write (use it with 'scan reconstruct --rig')")->required();
  regc->add_flag("--sequential", gf->sequential, "chain pairwise fits K1 <- K2 <- K3 <- ... instead (the baseline)");
  regc->add_option("--upsample", gf->upsample, "up-sampling of the IR frames for corner detection (default 2)");
  regc->add_option("--corner-depth", gf->corner_depth, kCornerDepthHelp);
  regc->add_flag("--json", gf->json, "print a JSON summary on stdout");
  regc->callback([gf] { run_register(*gf); });
}

/// scan calibrate: each sensor's learned error compensation.
void add_calibrate_command(CLI::App* scan_cmd) {
  auto cf = std::make_shared<CalibrateFlags>();
  auto* cal = scan_cmd->add_subcommand(
      "calibrate", "learn each sensor's error compensation (linear regression on u, v, d) from chessboard frames");
  cal->add_option("recording", cf->recording, "recording of board frames (IR + depth), e.g. scan simulate --chessboard")
      ->required();
  cal->add_option("--out", cf->out, "model file to write (JSON, one entry per sensor)")->required();
  cal->add_option("--pattern", cf->pattern, "inner corners COLSxROWS (default: rig.json \"chessboard\")");
  cal->add_option("--square-mm", cf->square_mm, "square side [mm] (default: rig.json \"chessboard\")");
  cal->add_option("--truth", cf->truth,
                  "true corners from: pnp (board pose from the IR image, default) | kabsch (thesis: rigid fit to the "
                  "measured corners)");
  cal->add_option("--upsample", cf->upsample, "IR up-sampling for corner detection, 1 to 8 (default 2)");
  add_compensation_form_flags(*cal, cf->model, cf->depth_degree, cf->refine_distortion);
  cal->add_option("--corner-depth", cf->corner_depth,
                  "depth at each corner of the training frames: bilinear (the thesis, default) | plane (a robust local "
                  "plane fit of the pixels within 6 px)");
  cal->add_option("--min-frames", cf->min_frames, "fewest usable board frames (poses) per sensor (default 5)");
  cal->add_option("--frames-per-pose", cf->frames_per_pose,
                  "consecutive frames of one board pose, fused into one observation (default: rig.json "
                  "\"frames_per_pose\", else 1)");
  cal->add_option("--fusion", cf->fusion,
                  "depth fusion of a pose's frames: trimmed-mean (default) | median; IR frames are averaged");
  cal->add_flag("--json", cf->json, "print a JSON summary on stdout");
  cal->callback([cf] { run_calibrate(*cf); });
}

/// scan experiment limb: a rig around a limb, reconstructed and measured against it.
void add_limb_experiment_command(CLI::App* exp) {
  auto lf = std::make_shared<LimbExperimentFlags>();
  auto* limb = exp->add_subcommand(
      "limb", "simulate a rig around a limb, reconstruct it and measure the surface distance to the original");
  limb->add_option("--mesh", lf->mesh, "limb surface (STL/OBJ/PLY/AOP), long axis along z, proximal end up");
  limb->add_option("--units", lf->units, "units of --mesh: mm | m (default: guessed)");
  limb->add_option("--generated", lf->generated, "use the generated limb's skin: transtibial | transfemoral");
  limb->add_option("--limb-seed", lf->limb_seed, "seed of the generated limb (default 1)");
  add_session_flags(*limb, *lf,
                    "learned models of K1..Kn (from 'scan experiment chessboard' or 'scan calibrate' with the same "
                    "--seed and --calibration), applied by the back-projection");
  limb->add_option("--radius-mm", lf->radius_mm, "ring radius [mm] (default 750)");
  limb->add_option("--height-mm", lf->height_mm, "sensor height above the limb's centre [mm] (default 0)");
  add_surface_flags(*limb, lf->grid_mm, lf->facet_mm, lf->smooth);
  limb->add_option("--fusion", lf->fusion,
                   "per-pixel fusion of each sensor's --frames: median (default) | trimmed-mean");
  limb->add_option("--spacing-mm", lf->spacing_mm, "sample spacing of the distance measure [mm] (default 2)");
  limb->add_option("--out", lf->out, "folder for the recording, the surfaces and report.json")->required();
  limb->add_flag("--json", lf->json, "print the report on stdout");
  limb->callback([lf] { run_limb_experiment(*lf); });
}

/// scan experiment registration: Table 4, sequential vs multi-set registration.
void add_registration_experiment_command(CLI::App* exp) {
  auto xf = std::make_shared<RegistrationExperimentFlags>();
  auto* xreg = exp->add_subcommand(
      "registration", "Table 4: sequential vs multi-set registration on a simulated box session from perturbed poses");
  add_session_flags(*xreg, *xf,
                    "learned models of K1..Kn (compensation.json of 'scan experiment chessboard' or 'scan calibrate' "
                    "with the same --seed and --calibration): adds the multi-set + compensation row");
  xreg->add_option("--corner-depth", xf->corner_depth, kCornerDepthHelp);
  xreg->add_option("--box-yaw-deg", xf->box_yaw_deg, "turn of the box about the vertical [deg] (default 45)");
  xreg->add_option("--pose-error-deg", xf->pose_error_deg, "rotation error of the starting poses [deg] (default 3)");
  xreg->add_option("--pose-error-mm", xf->pose_error_mm, "translation error of the starting poses [mm] (default 20)");
  xreg->add_option("--pose-seed", xf->pose_seed, "seed of the starting pose errors (default 7)");
  xreg->add_option("--out", xf->out, "folder for the box recording, the rig files and report.json")->required();
  xreg->add_flag("--json", xf->json, "print the report on stdout");
  xreg->callback([xf] { run_registration_experiment(*xf); });
}

/// scan experiment chessboard|cylinders: Table 3 and the cylinders, raw vs compensated.
void add_board_experiment_commands(CLI::App* exp) {
  for (const char* which : {"chessboard", "cylinders"}) {
    auto ef = std::make_shared<ExperimentFlags>();
    ef->which = which;
    auto* x = exp->add_subcommand(
        which, std::string(which) == "chessboard"
                   ? "Table 3: chessboard dimension errors on held-out frames without/with the learned compensation"
                   : "cylinders of 10, 16, 21 cm: RMSE and max error without/with the learned compensation");
    x->add_option("--out", ef->out, "folder for <which>.json and the learned compensation.json")->required();
    x->add_option("--seed", ef->seed, "seed of the units' errors, poses and noise (default 1)");
    x->add_option("--sensors", ef->sensors, "sensors K1..Kn (default 4)");
    x->add_option("--frames", ef->frames, "training board poses per sensor (default 50, as the thesis)");
    x->add_option("--board-frames-per-pose", ef->board_frames_per_pose,
                  "frames recorded of each training board pose and fused (IR mean, depth trimmed mean; default 1); "
                  "the held-out frames stay single frames");
    x->add_option("--test-frames", ef->test_frames, "held-out frames per sensor at each of 60, 75, 90 cm (default 5)");
    x->add_option("--noise-scale", ef->noise_scale, "scale of every simulated error term (default 1)");
    x->add_option("--systematic-scale", ef->systematic_scale, kSystematicScaleHelp);
    x->add_option("--calibration", ef->calibration,
                  "iai_kinect2 calibration folder(s) for the simulated units' intrinsics and distortion, as for scan "
                  "simulate (default: typical Kinect v2 intrinsics)");
    x->add_option("--truth", ef->truth, "pnp (default) | kabsch (thesis eqs. 31-35)");
    add_compensation_form_flags(*x, ef->model, ef->depth_degree, ef->refine_distortion);
    x->add_option("--corner-depth", ef->corner_depth,
                  "depth at the corners of the training frames: bilinear (the thesis, default) | plane (local plane "
                  "fit); the held-out frames are always measured the thesis's way (bilinear)");
    if (std::string(which) == "cylinders") {
      x->add_flag("--no-mesh", ef->no_mesh, "point-cloud errors only (skip the reconstructions)");
      x->add_option("--scan-frames", ef->scan_frames,
                    "frames per sensor of each cylinder scan, fused per pixel (default 1)");
      x->add_option("--fusion", ef->fusion,
                    "per-pixel fusion of the --scan-frames: median (default) | trimmed-mean");
    }
    x->add_flag("--json", ef->json, "print the results as JSON on stdout");
    x->callback([ef] { run_experiment(*ef); });
  }
}

}  // namespace

void register_scan(CLI::App& app) {
  auto* scan_cmd = add_command_group(app, "scan", "multi-sensor depth scans: simulate a Kinect v2 rig, reconstruct a limb");
  add_simulate_command(scan_cmd);
  add_reconstruct_command(scan_cmd);
  auto* exp = add_command_group(*scan_cmd, "experiment", "the thesis's scan experiments on simulated recordings");
  add_limb_experiment_command(exp);
  add_register_command(scan_cmd);
  add_registration_experiment_command(exp);
  add_calibrate_command(scan_cmd);
  add_board_experiment_commands(exp);
}

}  // namespace socketsmith::cli
