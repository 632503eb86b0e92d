// `socketsmith compare A B`: two shapes of one limb (scan vs scan, scan vs socket) aligned and
// compared: deviation map (PNG, VTK), slices (CSV), compare.json and compare.html.
#include <filesystem>

#include "cli_common.h"
#include "socketsmith/core/errors.h"
#include "socketsmith/core/log.h"
#include "socketsmith/pipeline/shape_comparison.h"

namespace socketsmith::cli {
namespace {

struct CompareFlags {
  std::string a, b, out, units, b_kind = "auto", seed = "auto", landmarks_a, landmarks_b;
  double crop_mm = 0, range_mm = 0, slice_mm = 10, scale = 1;
  bool json = false;
};

void run(const CompareFlags& f) {
  pipeline::CompareRunOptions o;
  if (!f.units.empty()) o.units = units::parse_length_unit(f.units);
  o.scale = f.scale;
  o.range_m = f.range_mm * 1e-3;
  o.compare.b_kind = geometry::parse_shape_kind(f.b_kind);
  o.compare.seed = geometry::parse_alignment_seed(f.seed);
  require(o.compare.seed != geometry::AlignmentSeed::Landmarks || !f.landmarks_a.empty(),
          "compare: --seed landmarks needs --landmarks-a FILE and --landmarks-b FILE");
  o.compare.crop_height_m = f.crop_mm * 1e-3;
  o.compare.slice_step_m = f.slice_mm * 1e-3;
  o.landmarks_a = f.landmarks_a;
  o.landmarks_b = f.landmarks_b;
  const nlohmann::json j = pipeline::run_compare(f.a, f.b, f.out, o);
  if (f.json) {
    print_json(j);
    return;
  }
  log::info("compare: B ({}) aligned onto A by {}: rotation {:.2f} deg, translation {:.2f} mm; residual {:.3f} mm, "
            "uniform offset {:+.3f} mm",
            j["b_kind"].get<std::string>(), j["seed"].get<std::string>(), j["transform_b_to_a"]["angle_deg"].get<double>(),
            std::hypot(j["transform_b_to_a"]["translation_mm"][0].get<double>(),
                       j["transform_b_to_a"]["translation_mm"][1].get<double>(),
                       j["transform_b_to_a"]["translation_mm"][2].get<double>()),
            j["icp"]["rms_mm"].get<double>(), j["icp"]["uniform_offset_mm"].get<double>());
  const auto& d = j["deviation"];
  log::info("compare: deviation B − A below {:.0f} mm: mean {:+.2f} mm, SD {:.2f} mm, 5th–95th percentile {:+.2f} … "
            "{:+.2f} mm ({} of {} points covered)",
            j["crop_height_mm"].get<double>(), d["mean_mm"].get<double>(), d["sd_mm"].get<double>(),
            d["p05_mm"].is_null() ? 0.0 : d["p05_mm"].get<double>(), d["p95_mm"].is_null() ? 0.0 : d["p95_mm"].get<double>(),
            d["covered"].get<int>(), d["points"].get<int>());
  log::info("compare: volume below the crop A {:.1f} cm^3, B {:.1f} cm^3: change {:+.1f} cm^3 ({:+.2f} %)",
            j["volume"]["a_cm3"].get<double>(), j["volume"]["b_cm3"].get<double>(), j["volume"]["change_cm3"].get<double>(),
            j["volume"]["change_percent"].get<double>());
  log::info("compare: page {}", (std::filesystem::path(f.out) / "compare.html").string());
}

}  // namespace

void register_compare(CLI::App& app) {
  auto f = std::make_shared<CompareFlags>();
  auto* cmd = app.add_subcommand("compare", "align two shapes of a limb (scan vs scan, scan vs socket) and map their deviation");
  cmd->add_option("a", f->a, "reference shape A: a limb scan (STL/OBJ/PLY)")->required();
  cmd->add_option("b", f->b, "shape B aligned onto A: a limb scan, or a socket solid (its cavity is compared)")->required();
  cmd->add_option("--out", f->out, "output directory")->required();
  cmd->add_option("--b-kind", f->b_kind, "what B is: auto (default) | surface | socket")
      ->check(CLI::IsMember({"auto", "surface", "socket"}));
  cmd->add_option("--seed", f->seed,
                  "alignment start: auto (default: landmarks when given, else the best of the identity and the limb "
                  "frames) | frames | landmarks | identity | none (no alignment)");
  cmd->add_option("--landmarks-a", f->landmarks_a, "JSON {\"PT\": [x, y, z], ...} on A, in A's unit");
  cmd->add_option("--landmarks-b", f->landmarks_b, "the same codes on B");
  cmd->add_option("--crop-mm", f->crop_mm,
                  "compare below this height above A's distal end [mm] (default: 5 mm below the lower opening)")
      ->check(non_negative());
  cmd->add_option("--range-mm", f->range_mm, "colour range of the deviation map: ±R mm (default: automatic)")
      ->check(non_negative());
  cmd->add_option("--slice-mm", f->slice_mm, "slice spacing [mm] (default 10)")->check(positive());
  cmd->add_option("--units", f->units, "unit of both files: mm | m (default: guessed from the size)");
  cmd->add_option("--scale", f->scale, "multiply both shapes by this after reading (e.g. a normalised limb)")
      ->check(positive());
  cmd->add_flag("--json", f->json, "print the summary as JSON on stdout");
  cmd->callback([f] { run(*f); });
}

}  // namespace socketsmith::cli
