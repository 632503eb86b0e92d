// `socketsmith limb generate`: the parametric residual limb (skin + bones) as a multi-shell mesh
// in mm, with a JSON sidecar (parameters, frame, landmarks). `socketsmith limb brims`: the brim
// templates placed on the generated limbs, as the docs' figure.
#include <chrono>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <limits>

#include "cli_common.h"
#include "socketsmith/core/errors.h"
#include "socketsmith/core/log.h"
#include "socketsmith/geometry/mesh_checks.h"
#include "socketsmith/geometry/mesh_io.h"
#include "socketsmith/pipeline/brim_figure.h"
#include "socketsmith/volume/limb_generator.h"

namespace socketsmith::cli {
namespace {

struct LimbFlags {
  std::string type;
  std::string side = "right";
  std::uint64_t seed = 1;
  double length_mm = std::numeric_limits<double>::quiet_NaN();  // NaN: from the seed
  bool open = false;
  bool closed = false;
  std::string out;
  bool json = false;
};

void run_generate(const LimbFlags& f) {
  namespace fs = std::filesystem;
  const auto t0 = std::chrono::steady_clock::now();
  const geometry::LimbType type = geometry::parse_limb_type(f.type);
  const geometry::Side side = geometry::parse_side(f.side);
  const fs::path out(f.out);
  std::string ext = out.extension().string();
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  require(ext == ".stl" || ext == ".obj" || ext == ".ply" || ext == ".aop",
          "limb generate: --out '{}' has extension '{}' (expected .stl, .obj, .ply or .aop; the sidecar goes beside it as .json)",
          f.out, ext);
  volume::LimbShapeParams p = volume::default_params(type, f.seed);
  p.side = side;
  p.open_proximal = !f.closed;
  if (!std::isnan(f.length_mm)) {
    const auto [lo, hi] = volume::residual_length_range(type);
    require(std::isfinite(f.length_mm) && f.length_mm > 0.0,
            "limb generate: --length-mm {} is not a positive length (expected the residual length in mm, {:.0f} to "
            "{:.0f} for a {} limb)",
            f.length_mm, lo / units::mm, hi / units::mm, geometry::to_string(type));
    require(f.length_mm * units::mm >= lo && f.length_mm * units::mm <= hi,
            "limb generate: --length-mm {} is out of range (expected {:.0f} to {:.0f} mm for a {} limb)", f.length_mm,
            lo / units::mm, hi / units::mm, geometry::to_string(type));
    p.residual_length_m = f.length_mm * units::mm;
  }
  const volume::GeneratedLimb limb = volume::generate_limb(p);
  const geometry::TriMesh merged = volume::merge_shells(limb);
  geometry::write_mesh(out, merged, units::LengthUnit::Millimetre);
  fs::path sidecar = out;
  sidecar.replace_extension(".json");
  volume::write_limb_sidecar(sidecar, limb);
  const double wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();

  const double skin_volume = limb.skin_volume_m3;
  const auto rep = geometry::check_mesh(limb.skin);
  std::string bone_list;
  for (const auto& b : limb.bones) bone_list += (bone_list.empty() ? "" : ", ") + b.name;
  std::string landmark_list;
  for (const auto& l : limb.landmarks) landmark_list += (landmark_list.empty() ? "" : " ") + l.code;
  const bool tt = type == geometry::LimbType::Transtibial;

  nlohmann::json j = volume::limb_sidecar_json(limb);
  j["command"] = "socketsmith limb generate";
  j["outputs"] = {out.string(), sidecar.string()};
  j["skin_volume_l"] = skin_volume * 1e3;
  j["skin_boundary_loops"] = rep.boundary_loops;
  j["wall_s"] = wall_s;
  if (f.json) {
    print_json(j);
    return;
  }
  log::info(
      "{} {} limb (seed {}): residual {:.0f} mm {}{}, circumference {:.0f} mm {} and {:.0f} mm distally, "
      "bulbousness {:.2f}; skin {} vertices, {} ({} boundary loop{}), volume {:.2f} l; bones: {}; landmarks: {}; "
      "wrote {} (mm) and {} in {:.2f} s.",
      geometry::to_string(side), geometry::to_string(type), f.seed, p.residual_length_m * 1e3,
      tt ? "below the knee joint line" : "from the proximal cut",
      tt ? fmt::format(" + {:.0f} mm above", p.proximal_extension_m * 1e3) : std::string(),
      p.proximal_circumference_m * 1e3, tt ? "at the knee" : "proximally", p.distal_circumference_m * 1e3,
      p.bulbousness, limb.skin.num_vertices(), p.open_proximal ? "open at the proximal cut" : "capped",
      rep.boundary_loops, rep.boundary_loops == 1 ? "" : "s", skin_volume * 1e3, bone_list, landmark_list, out.string(),
      sidecar.string(), wall_s);
}

}  // namespace

void register_limb(CLI::App& app) {
  auto* limb = add_command_group(app, "limb", "parametric residual limbs");
  auto flags = std::make_shared<LimbFlags>();
  auto* gen = limb->add_subcommand(
      "generate", "generate a seeded residual limb (skin + bones) as a multi-shell mesh in mm with a .json sidecar");
  gen->add_option("--type", flags->type, case_names_help("limb.type"))->required();
  gen->add_option("--side", flags->side, case_names_help("limb.side") + " (default right)");
  gen->add_option("--seed", flags->seed, "seed of the shape jitter (0: the nominal limb; default 1)");
  gen->add_option("--length-mm", flags->length_mm,
                  "residual length [mm]: knee joint line to distal end (transtibial), proximal cut to distal end "
                  "(transfemoral); default from the seed");
  auto* open = gen->add_flag("--open", flags->open, "open proximal end, one boundary loop at the cut like a scan (default)");
  auto* closed = gen->add_flag("--closed", flags->closed, "cap the proximal end with a planar cap");
  open->excludes(closed);
  gen->add_option("--out", flags->out, "output mesh: .stl, .obj, .ply or .aop (AAOP: 72 spokes x 100 slices about the limb's axis; the sidecar is written beside it as .json)")
      ->required();
  gen->add_flag("--json", flags->json, "print the sidecar and a summary as JSON on stdout");
  gen->callback([flags] { run_generate(*flags); });

  // The brim templates as placed on the generated limbs: docs/images/brim_templates.svg.
  auto fig = std::make_shared<std::pair<std::string, std::uint64_t>>("", 0);
  auto* brims = limb->add_subcommand(
      "brims", "draw every brim template placed on the generated transtibial and transfemoral limbs (SVG figure)");
  brims->add_option("--out", fig->first, "output SVG (docs/images/brim_templates.svg regenerates the docs' figure)")
      ->required();
  brims->add_option("--seed", fig->second, "seed of the generated limbs (default 0: the nominal limbs)");
  brims->callback([fig] {
    require(std::filesystem::path(fig->first).extension() == ".svg", "limb brims: --out '{}' must end in .svg",
            fig->first);
    pipeline::write_brim_template_figure(fig->first, fig->second);
    log::info("limb brims: wrote {}", fig->first);
  });
}

}  // namespace socketsmith::cli
