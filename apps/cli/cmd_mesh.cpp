// `socketsmith mesh`: limb surface (+ bones) -> hexahedral MSS-CS-ready stump with landmarks. The
// flags and files become a prepared limb here; the mesh and its files are pipeline::run_stump_mesh's.
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <sstream>

#include "cli_common.h"
#include "socketsmith/core/errors.h"
#include "socketsmith/core/log.h"
#include "socketsmith/core/progress.h"
#include "socketsmith/core/units.h"
#include "socketsmith/design/case_file.h"
#include "socketsmith/geometry/mesh_checks.h"
#include "socketsmith/geometry/mesh_io.h"
#include "socketsmith/pipeline/stump_mesh.h"
#include "socketsmith/volume/hex_mesher.h"
#include "socketsmith/volume/limb_model.h"

namespace socketsmith::cli {
namespace {

using geometry::Vec3;

struct MeshFlags {
  std::string limb;
  std::string bones = "auto";
  std::string units;
  double scale = 1.0;
  std::string type = "transtibial";
  std::string anterior;
  std::string axis;
  bool force_size = false;
  std::string side;
  double cut_height_mm = -1.0;
  int target_nodes = 8000;
  std::vector<std::string> landmarks;  // CODE=x,y,z in the file's unit (after --scale)
  double load_kpa = 0.0;
  ModelFlags model;
  std::string out;
  bool json = false;
};

/// Parses a point "x,y,z" (finite). Directions go through design::parse_limb_direction.
Vec3 parse_point(const std::string& text, const std::string& what) {
  Vec3 v;
  char c1 = 0, c2 = 0;
  std::istringstream in(text);
  in >> v.x() >> c1 >> v.y() >> c2 >> v.z();
  require(in && c1 == ',' && c2 == ',' && v.allFinite(), "{} '{}' is not a point x,y,z (e.g. 12.5,-80,160)", what, text);
  return v;
}

/// Reads a mesh in metres, then applies --scale. @p unit_m receives the file unit in metres,
/// @p file what the file says beside its surface (an AAOP file's side and landmarks).
geometry::TriMesh read_scaled(const std::string& path, const MeshFlags& f, double* unit_m = nullptr,
                              geometry::MeshReadInfo* file = nullptr) {
  geometry::MeshReadOptions ro;
  if (!f.units.empty()) ro.unit = units::parse_length_unit(f.units);
  if (f.scale != 1.0) ro.warn_on_implausible_size = false;
  geometry::MeshReadInfo info;
  geometry::TriMesh m = geometry::read_mesh(path, ro, &info);
  if (unit_m) *unit_m = units::to_metres(info.unit);
  if (file) *file = info;
  if (f.scale != 1.0) geometry::scale(m, f.scale);
  return m;
}

/// Refuses a scale, node target or test load out of range.
void check_mesh_flags(const MeshFlags& f) {
  require(f.scale > 0.0 && std::isfinite(f.scale), "--scale {} must be positive", f.scale);
  require(f.target_nodes >= 100 && f.target_nodes <= 2000000, "--target-nodes {} outside [100, 2000000]",
          f.target_nodes);
  require(f.load_kpa >= 0.0 && f.load_kpa <= 500.0, "--load-kpa {} outside [0, 500] kPa", f.load_kpa);
}

/// The limb file, a separate bone file (when given), the limb file's unit and the options of
/// volume::prepare_limb from the flags.
struct MeshInput {
  geometry::TriMesh limb, extra;
  double file_unit_m = 1.0;
  volume::LimbInputOptions lo;
};

MeshInput read_mesh_input(const MeshFlags& f) {
  MeshInput in;
  geometry::MeshReadInfo file;
  in.limb = read_scaled(f.limb, f, &in.file_unit_m, &file);
  volume::LimbInputOptions& lo = in.lo;
  lo.type = geometry::parse_limb_type(f.type);
  if (f.bones != "auto" && f.bones != "estimate" && f.bones != "none") in.extra = read_scaled(f.bones, f);
  // The case file's own check of limb.axis / limb.anterior (one validator for both).
  if (!f.anterior.empty())
    lo.anterior = design::parse_limb_direction(f.anterior, design::LimbDirection::Anterior, "mesh --anterior");
  if (!f.axis.empty()) lo.axis = design::parse_limb_direction(f.axis, design::LimbDirection::Axis, "mesh --axis");
  lo.force_size = f.force_size;
  if (!f.side.empty()) lo.side = geometry::parse_side(f.side);
  for (const auto& note : volume::apply_file_hints(lo, file)) log::info("mesh: {}", note);
  if (f.cut_height_mm > 0) lo.cut_height_m = f.cut_height_mm * units::mm;
  lo.estimate_bones = f.bones != "none";
  return in;
}

/// The limb prepared from its file (with --bones estimate or none, its largest shell only), and
/// the landmarks the user moved.
volume::LimbModel prepare_mesh_limb(const MeshFlags& f, const MeshInput& in) {
  geometry::TriMesh skin_only = in.limb;
  if (f.bones == "estimate" || f.bones == "none") {
    // Ignore bone shells in the limb file: keep the largest shell only.
    auto parts = geometry::split_components(in.limb);
    std::sort(parts.begin(), parts.end(), [](const auto& a, const auto& b) {
      return geometry::surface_area(a) > geometry::surface_area(b);
    });
    skin_only = parts.front();
  }
  volume::LimbModel model = volume::prepare_limb(skin_only, in.extra, in.lo);
  for (const auto& text : f.landmarks) {
    const auto eq = text.find('=');
    require(eq != std::string::npos && eq > 0, "--landmark '{}' is not CODE=x,y,z (e.g. PT=12.5,-80,160)", text);
    volume::Landmark given;
    given.code = text.substr(0, eq);
    given.position = parse_point(text.substr(eq + 1), "--landmark " + given.code) * in.file_unit_m * f.scale;
    volume::override_landmark(model.landmarks, model.skin, model.frame, given);
    model.notes.push_back(fmt::format("landmark {} given by the user", given.code));
  }
  return model;
}

/// The mesh's size, quality and tissue volume, one line each, and where the stump was written.
void log_mesh_summary(const volume::LimbModel& model, const volume::HexMesherResult& r,
                      const std::filesystem::path& out) {
  const double tissue_ref = r.skin_volume_m3 - r.bone_volume_m3;
  log::info("mesh: {} nodes, {} hexahedra ({} fixed, {} on the skin), cell {:.1f} mm, {:.1f} s", r.mesh.num_nodes(),
            r.mesh.num_hexahedra(), r.mesh.count_tag(volume::kNodeFixed), r.mesh.count_tag(volume::kNodeSurface),
            r.cell_size_m * 1e3, r.seconds);
  log::info("mesh: scaled Jacobian min {:.3f} mean {:.3f}, max aspect ratio {:.2f}, skin nodes within {:.3f} mm "
            "of the skin, quad centres within {:.2f} mm",
            r.quality.min_scaled_jacobian, r.quality.mean_scaled_jacobian, r.quality.max_aspect_ratio,
            r.max_skin_distance_m * 1e3, r.max_face_deviation_m * 1e3);
  log::info("mesh: tissue volume {:.1f} cm^3 vs skin - bones {:.1f} cm^3 ({:+.2f} %){}", r.tissue_volume_m3 * 1e6,
            tissue_ref * 1e6, tissue_ref > 0 ? 100 * (r.tissue_volume_m3 / tissue_ref - 1.0) : 0.0,
            model.bones_estimated ? "; bones ESTIMATED" : "");
  log::info("mesh: wrote {}", (out / "stump.vtu").string());
}

void run(const MeshFlags& f) {
  namespace fs = std::filesystem;
  check_mesh_flags(f);
  const MeshInput in = read_mesh_input(f);

  const auto progress = console_progress(1.0);  // stderr: keeps --json output clean
  report_progress(progress, 0.0, "mesh: preparing the limb");
  const volume::LimbModel model = prepare_mesh_limb(f, in);
  for (const auto& n : model.notes) log::info("mesh: {}", n);

  pipeline::StumpMeshRequest q;
  q.limb_file = f.limb;
  q.target_nodes = f.target_nodes;
  q.test_pressure_pa = f.load_kpa * units::kPa;
  q.model = make_model_options(f.model);
  q.material = make_material(f.model);
  q.progress = progress;
  const fs::path out(f.out);
  const pipeline::StumpMesh m = pipeline::run_stump_mesh(model, q, out);
  if (f.json)
    print_json(m.summary);
  else
    log_mesh_summary(model, m.mesher, out);
}

}  // namespace

void register_mesh(CLI::App& app) {
  auto f = std::make_shared<MeshFlags>();
  auto* cmd = app.add_subcommand("mesh", "hexahedral stump mesh from a limb surface (and bones)");
  cmd->add_option("--limb", f->limb, "limb surface: STL/OBJ/PLY/AOP, may be open proximally, may hold bone shells")
      ->required()
      ->check(CLI::ExistingFile);
  cmd->add_option("--bones", f->bones,
                  "bones: FILE | auto (shells of the limb file, else estimated) | estimate | none");
  cmd->add_option("--units", f->units, "length unit of the files: mm | m (default: guessed from the size)");
  cmd->add_option("--scale", f->scale, "multiply coordinates after unit conversion (e.g. 0.45 for femur-normalised shapes)");
  cmd->add_option("--type", f->type, case_names_help("limb.type"));
  cmd->add_option("--anterior", f->anterior, "front of the limb as a direction x,y,z in the file's frame");
  cmd->add_option("--axis", f->axis,
                  "long axis of the limb, distal to proximal, as x,y,z in the file's frame (default: the femur's "
                  "shaft, else estimated from the skin)");
  cmd->add_flag("--force-size", f->force_size,
                "accept a limb whose size after units and --scale is outside the anatomical range of its type");
  cmd->add_option("--side", f->side, case_names_help("limb.side"));
  // The case file's range (a cut of 0 or below was silently read as "not given").
  cmd->add_option("--cut-height-mm", f->cut_height_mm, "proximal cut above the distal end (default: just below the open rim)")
      ->check(within(design::limits::kCutHeight));
  cmd->add_option("--target-nodes", f->target_nodes, "aimed-at node count (e.g. 3000, 8000, 20000)");
  cmd->add_option("--landmark", f->landmarks,
                  "move a landmark: CODE=x,y,z in the file's unit, projected onto the skin (repeatable)");
  cmd->add_option("--load-kpa", f->load_kpa, "also solve the MSS-CS stump under this uniform inward skin pressure");
  add_model_flags(*cmd, f->model);
  cmd->add_option("--out", f->out, "output directory")->required();
  cmd->add_flag("--json", f->json, "print the summary as JSON on stdout");
  cmd->callback([f] { run(*f); });
}

}  // namespace socketsmith::cli
