// `socketsmith check mesh FILE`: reads a surface mesh and reports what a user must know before
// using it (units, size, closed, manifold, orientation, components, self-intersections).
#include "cli_common.h"
#include "socketsmith/core/errors.h"
#include "socketsmith/core/log.h"
#include "socketsmith/geometry/mesh_checks.h"
#include "socketsmith/geometry/mesh_io.h"
#include "socketsmith/geometry/mesh_report.h"

namespace socketsmith::cli {
namespace {

struct CheckFlags {
  std::string file;
  std::string units;
  bool json = false;
  bool require_closed = false;
};

void run(const CheckFlags& f) {
  geometry::MeshReadOptions ro;
  if (!f.units.empty()) ro.unit = units::parse_length_unit(f.units);
  geometry::MeshReadInfo info;
  const geometry::TriMesh mesh = geometry::read_mesh(f.file, ro, &info);
  const auto rep = geometry::check_mesh(mesh);
  const auto box = geometry::bounding_box(mesh);
  const nlohmann::json j = geometry::mesh_report_json(f.file, mesh, info);
  if (f.json) {
    print_json(j);
  } else {
    log::info("{}: {} vertices, {} triangles, {:.1f} x {:.1f} x {:.1f} mm, {} component(s), {}", f.file,
              rep.num_vertices, rep.num_triangles, box.extent().x() * 1e3, box.extent().y() * 1e3,
              box.extent().z() * 1e3, rep.connected_components, rep.is_closed() ? "closed" : "open");
    for (const auto& p : j["problems"]) log::info("  {}", p.get<std::string>());  // with self-intersections
    for (const auto& lm : info.landmarks)
      log::info("  landmark {}: {} point(s), the first at ({:.1f}, {:.1f}, {:.1f}) mm", lm.name, lm.points.size(),
                lm.points[0].x() * 1e3, lm.points[0].y() * 1e3, lm.points[0].z() * 1e3);
  }
  if (f.require_closed) geometry::require_closed_surface(mesh, "'" + f.file + "'");
}

}  // namespace

void register_check(CLI::App& app) {
  auto* chk = add_command_group(app, "check", "inspect an input file");
  auto flags = std::make_shared<CheckFlags>();
  auto* mesh = chk->add_subcommand("mesh", "read a surface mesh (STL/OBJ/PLY/AOP) and report units, size and topology");
  mesh->add_option("file", flags->file, "mesh file")->required();
  mesh->add_option("--units", flags->units, "length unit of the file: mm | m (default: guessed from its size)")
      ->check(CLI::IsMember({"mm", "m"}));
  mesh->add_flag("--json", flags->json, "print the report as JSON");
  mesh->add_flag("--require-closed", flags->require_closed, "fail (exit 4) unless the surface is closed and manifold");
  mesh->callback([flags] { run(*flags); });
}

}  // namespace socketsmith::cli
