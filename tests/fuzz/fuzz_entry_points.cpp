#include "fuzz_entry_points.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <stdexcept>
#include <string>

#include "socketsmith/core/errors.h"
#include "socketsmith/core/json_input.h"
#include "socketsmith/core/log.h"
#include "socketsmith/design/brim.h"
#include "socketsmith/design/case_file.h"
#include "socketsmith/design/design_solver.h"
#include "socketsmith/design/optimizer.h"
#include "socketsmith/design/pain_map.h"
#include "socketsmith/geometry/mesh_checks.h"
#include "socketsmith/geometry/mesh_io.h"
#include "socketsmith/pipeline/design_pipeline.h"
#include "socketsmith/volume/hex_mesher.h"
#include "socketsmith/volume/limb_generator.h"
#include "socketsmith/volume/limb_model.h"

namespace socketsmith::fuzz {
namespace {

std::string_view text_of(const std::uint8_t* data, std::size_t size) {
  return {reinterpret_cast<const char*>(data), size};
}

void mesh(std::string_view ext, const std::uint8_t* data, std::size_t size) {
  geometry::MeshReadOptions o;
  o.warn_on_implausible_size = false;
  const auto m = geometry::read_mesh_data(text_of(data, size), "fuzz." + std::string(ext), o);
  (void)geometry::check_mesh(m);
}

/// The format of a limb file by its content (the "limb" target has no file name): AAOP, PLY, a
/// binary STL whose size matches its triangle count, an ASCII STL ("solid"), else OBJ.
std::string limb_extension(std::string_view d) {
  if (d.substr(0, 4) == "AAOP") return "aop";
  if (d.substr(0, 3) == "ply") return "ply";
  if (d.size() >= 84) {
    std::uint32_t n = 0;
    std::memcpy(&n, d.data() + 80, 4);
    if (84 + 50 * static_cast<std::uint64_t>(n) == d.size()) return "stl";
  }
  return d.substr(0, 5) == "solid" ? "stl" : "obj";
}

/// What `socketsmith mesh --limb FILE --target-nodes 300` does with the file: read it, make the
/// limb model (skin, bones given or estimated, frame, landmarks), mesh the stump.
void limb(const std::uint8_t* data, std::size_t size) {
  const std::string_view text = text_of(data, size);
  geometry::MeshReadOptions o;
  o.warn_on_implausible_size = false;
  const auto m = geometry::read_mesh_data(text, "fuzz." + limb_extension(text), o);
  const volume::LimbModel model = volume::prepare_limb(m, {}, {});
  volume::HexMesherOptions mo;
  mo.target_nodes = 300;
  (void)volume::mesh_limb(volume::mesher_input(model), mo);
}

/// Equal documents, numbers within 1e-9 relative (mm -> m -> mm may move the last bit).
bool nearly_equal(const nlohmann::json& a, const nlohmann::json& b) {
  if (a.is_number() && b.is_number()) {
    const double x = a.get<double>(), y = b.get<double>();
    return std::abs(x - y) <= 1e-9 * std::max({1.0, std::abs(x), std::abs(y)});
  }
  if (a.type() != b.type() || a.size() != b.size()) return false;
  if (a.is_object()) {
    for (auto it = a.begin(); it != a.end(); ++it)
      if (!b.contains(it.key()) || !nearly_equal(it.value(), b.at(it.key()))) return false;
    return true;
  }
  if (a.is_array()) {
    for (size_t i = 0; i < a.size(); ++i)
      if (!nearly_equal(a[i], b[i])) return false;
    return true;
  }
  return a == b;
}

void case_file(const std::uint8_t* data, std::size_t size) {
  const auto doc = parse_json_input(text_of(data, size), "fuzz case");
  const design::CaseFile c = design::parse_case(doc);
  // A valid case written back must read back to the same case (the GUI saves, the CLI replays):
  // a write that the reader refuses, or a value that changes, is a finding.
  const auto written = design::case_to_json(c);
  if (!nearly_equal(design::case_to_json(design::parse_case(written)), written))
    throw std::logic_error("case_file: the case does not survive a write and a read: " + written.dump());
}

/// The generated sample limb meshed once at ~300 nodes (the design target's stump).
struct TinyStump {
  volume::LimbModel model;
  volume::HexMesh mesh;
};
const TinyStump& tiny_stump() {
  static const TinyStump stump = [] {
    TinyStump s;
    const auto g = volume::generate_limb(volume::default_params(geometry::LimbType::Transtibial, 1));
    s.model = volume::prepare_limb(volume::merge_shells(g), {}, {});
    volume::HexMesherOptions o;
    o.target_nodes = 300;
    s.mesh = volume::mesh_limb(volume::mesher_input(s.model), o).mesh;
    return s;
  }();
  return stump;
}

void design_case(const std::uint8_t* data, std::size_t size) {
  const design::CaseFile c = design::parse_case(parse_json_input(text_of(data, size), "fuzz case"));
  const TinyStump& s = tiny_stump();
  // The case's patient, tissue, thresholds, brim and spots on the stump, checked as
  // pipeline::prepare_design checks them (the limb and its meshing are the fixed stump's).
  auto table = c.thresholds.empty() ? design::default_thresholds(s.model.type) : c.thresholds;
  design::validate_thresholds(table, s.model.landmarks, s.model.type);
  const design::BrimTemplate kind = c.brim.value_or(design::default_brim(s.model.type));
  const design::BrimLine brim = c.brim_key_points.empty() ? design::make_brim(kind, s.model)
                                                          : design::brim_from_key_points(c.brim_key_points, kind);
  design::validate_brim(brim, s.model.skin, s.model.frame);
  const auto spots = c.spots.empty() ? design::default_spots(s.model.type, s.model.landmarks, s.model.length_m) : c.spots;
  for (const auto& sp : spots) design::validate_spot(sp, s.model.length_m);
  const auto skin = volume::extract_skin_surface(s.mesh);
  design::DesignSolverOptions so;
  so.mode = c.solve_mode;
  design::DesignSolver solver(s.mesh, pipeline::material(c), pipeline::model_options(c), s.model.frame,
                              design::threshold_map(skin.positions, s.model.landmarks, table), c.patient,
                              s.model.length_m, so);
  solver.set_brim([&brim](double theta) { return brim.height(theta); });
  if (!c.optimise) {
    (void)solver.solve(spots);
    return;
  }
  design::OptimizerOptions oo;
  oo.objective = c.objective;
  oo.model_pressure_limit = c.model_pressure_limit;
  oo.max_rounds = 2;
  oo.max_position_evaluations = 10;
  oo.time_limit_s = 1.0;  // the bound the CLI's --time-limit sets; a hang past it is a finding
  const auto r = design::optimise_design(solver, spots, oo);
  if (!r.state.radar.force_n.allFinite() || !r.state.radar.torque_nm.allFinite())
    throw std::logic_error("design: a non-finite radar left the optimiser: " + r.message);
}

}  // namespace

const std::vector<std::string_view>& targets() {
  static const std::vector<std::string_view> all{"stl", "obj", "ply", "limb", "case_file", "design"};
  return all;
}

void run(std::string_view target, const std::uint8_t* data, std::size_t size) {
  static const bool quiet = [] {
    log::set_level(log::Level::Off);
    return true;
  }();
  (void)quiet;
  const auto check_one_line = [](const Error& e) {
    const std::string m = e.what();
    if (m.empty() || m.find('\n') != std::string::npos)
      throw std::logic_error("an error message is not one line: '" + m + "'");
  };
  try {
    if (target == "stl" || target == "obj" || target == "ply") mesh(target, data, size);
    else if (target == "limb") limb(data, size);
    else if (target == "case_file") case_file(data, size);
    else if (target == "design") design_case(data, size);
    else throw std::invalid_argument("fuzz: unknown target '" + std::string(target) + "'");
  } catch (const InvalidInputError& e) {
    check_one_line(e);
  } catch (const IoError& e) {
    check_one_line(e);
  } catch (const SolverError& e) {
    check_one_line(e);
  } catch (const TopologyError& e) {
    check_one_line(e);
  }
}

}  // namespace socketsmith::fuzz
