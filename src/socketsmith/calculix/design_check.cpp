#include "socketsmith/calculix/design_check.h"

#include <algorithm>
#include <cmath>
#include <deque>
#include <limits>
#include <numbers>
#include <system_error>

#include "socketsmith/core/atomic_file.h"
#include "socketsmith/core/enum_names.h"
#include "socketsmith/core/errors.h"
#include "socketsmith/core/log.h"
#include "socketsmith/calculix/dat_reader.h"
#include "socketsmith/calculix/frd_reader.h"
#include "socketsmith/calculix/socket_shell.h"
#include "socketsmith/calculix/surface_pressure.h"
#include "socketsmith/report/design_report.h"

namespace socketsmith::calculix {
namespace {

/// Area-weighted mean of @p v over each node and its neighbours.
std::vector<double> smooth_one_ring(const std::vector<double>& v, const std::vector<std::vector<int>>& adj,
                                    const std::vector<double>& area) {
  std::vector<double> out(v.size());
  for (size_t i = 0; i < v.size(); ++i) {
    double sw = area[i], s = area[i] * v[i];
    for (int j : adj[i]) {
      sw += area[j];
      s += area[j] * v[j];
    }
    out[i] = sw > 0 ? s / sw : v[i];
  }
  return out;
}

/// Rings of skin quads from the nodes above the brim (0 there; 2^29 when there are none).
std::vector<int> brim_rings(const std::vector<std::vector<int>>& adj, const std::vector<char>& above) {
  const int n = static_cast<int>(adj.size());
  std::vector<int> ring(n, 1 << 29);
  std::deque<int> queue;
  for (int i = 0; i < n; ++i)
    if (above[i]) {
      ring[i] = 0;
      queue.push_back(i);
    }
  while (!queue.empty()) {
    const int i = queue.front();
    queue.pop_front();
    for (int j : adj[i])
      if (ring[j] > ring[i] + 1) {
        ring[j] = ring[i] + 1;
        queue.push_back(j);
      }
  }
  return ring;
}

void check_input(const DesignedStump& d, const DesignCheckOptions& o) {
  require(d.mesh && d.skin, "check_design: no stump mesh or skin surface");
  require(!o.printed_wall || o.mode == DesignCheckMode::Donning,
          "check_design: the printed socket's wall is the donning check's socket (--printed-wall needs --mode donning)");
  const size_t nn = d.mesh->nodes.size(), ns = d.skin->nodes.size();
  require(d.designed_positions.size() == nn, "check_design: {} designed positions for {} nodes", d.designed_positions.size(), nn);
  require(d.pressure_pa.size() == ns && d.skin_normals.size() == ns && d.skin_areas_m2.size() == ns && d.above_brim.size() == ns,
          "check_design: per-skin-node fields have sizes {}, {}, {}, {} (expected {} skin nodes)", d.pressure_pa.size(),
          d.skin_normals.size(), d.skin_areas_m2.size(), d.above_brim.size(), ns);
  require(o.clearance_m > 0, "check_design: clearance {} m (expected > 0)", o.clearance_m);
  require(o.socket_thickness_m > 0, "check_design: socket thickness {} m (expected > 0)", o.socket_thickness_m);
  require(!(o.shell_on_wall || o.shell_lip) || d.wall_surface,
          "check_design: the shell on socketsmith's wall or lip needs that wall (DesignedStump::wall_surface; a design "
          "that does not meet its constraints has no socket)");
  require(!o.printed_wall || (!o.shell_on_wall && !o.shell_lip && o.shell_subdivision == 1),
          "check_design: the printed wall is donned as built (no shell to split, lay on the wall or give a lip)");
  require(o.shell_subdivision >= 1 && o.shell_subdivision <= 4,
          "check_design: shell subdivision {} (expected 1–4: each skin quad of the socket split n × n)", o.shell_subdivision);
  require(std::isfinite(o.stand_force_n) && o.stand_force_n >= 0,
          "check_design: standing force {} N (expected ≥ 0: half the body weight)", o.stand_force_n);
  require(o.stand_force_n == 0 || (std::isfinite(o.stand_travel_m) && o.stand_travel_m != 0),
          "check_design: standing travel {} m (expected a push ≠ 0 past the donned pose with a standing force)",
          o.stand_travel_m);
  require(o.stand_force_n == 0 || o.mode == DesignCheckMode::Donning,
          "check_design: a standing load needs the donning mode (the socket is pushed up after donning)");
  require(std::any_of(d.above_brim.begin(), d.above_brim.end(), [](char c) { return !c; }),
          "check_design: every skin node is above the brim (no socket to check)");
}

/// The deck's title, stump, supports, material and steps from the options; socket or loads to come.
DeckSpec base_deck(const DesignedStump& d, const DesignCheckOptions& o) {
  DeckSpec spec;
  spec.title = fmt::format("socketsmith validate design ({} check)", to_string(o.mode));
  spec.stump = d.mesh;
  spec.fixed_nodes = d.fixed_nodes;
  spec.material = o.material;
  spec.element = o.element;
  spec.contact = o.contact;
  spec.steps.is_nonlinear_geometry = o.nonlinear_geometry;
  spec.steps.initial_increment = o.initial_increment;
  spec.steps.max_increment = std::max(o.max_increment, o.initial_increment);
  spec.steps.min_increment = std::min(1e-5, o.initial_increment);
  return spec;
}

/// Donning mode: the designed socket (the printed wall, or the shell on the skin), rigid, moved
/// distally by the travel; the steps push it back up by the reference node, then stand on it.
RigidShell donning_socket(const DesignedStump& d, const DesignCheckOptions& o,
                          const std::vector<std::array<int, 4>>& socket_quads, DeckSpec& spec) {
  require(o.donning_travel_m > 0, "check_design: donning travel {} m (expected > 0)", o.donning_travel_m);
  // The designed socket, rigid, moved distally; pushed back up by the reference node.
  const Vec3 down = -o.donning_travel_m * d.frame.axis.normalized();
  RigidShell shell;
  if (o.printed_wall) {
    require(!d.socket_wall.empty(), "check_design: the printed socket's wall is empty (DesignedStump::socket_wall)");
    std::vector<Vec3> moved = d.socket_wall.vertices;
    for (auto& v : moved) v += down;
    shell = extrude_wall(moved, d.socket_wall.triangles, o.socket_thickness_m);
  } else {
    shell = donned_skin_shell(d, socket_quads, down, o);
  }
  spec.steps.donning_travel_m = -down;
  if (o.stand_force_n > 0) {
    spec.steps.stand_travel_m = o.stand_travel_m;
    spec.steps.load_direction = d.frame.axis.normalized();
  }
  return shell;
}

/// Contact mode: the socket's shell extruded from the rest skin, the clearance off it, its nodes
/// moved in the deck onto the designed skin (inner layer) and the thickness outside it (outer).
RigidShell contact_socket(const DesignedStump& d, const DesignCheckOptions& o,
                          const std::vector<std::array<int, 4>>& socket_quads, DeckSpec& spec) {
  const auto& mesh = *d.mesh;
  const auto& skin = *d.skin;
  const int ns = static_cast<int>(skin.nodes.size());
  std::vector<Vec3> start(ns), rest_normal(ns);
  for (int i = 0; i < ns; ++i) {
    rest_normal[i] = skin.normal[i].normalized();
    start[i] = mesh.nodes[skin.nodes[i]] + o.clearance_m * rest_normal[i];
  }
  RigidShell shell = extrude_shell(start, rest_normal, socket_quads, o.socket_thickness_m);
  const int ni = static_cast<int>(shell.source_points.size());
  if (ni > 0) spec.socket_node_displacements.resize(shell.nodes.size());
  for (int k = 0; k < ni; ++k) {
    const int i = shell.source_points[k];
    const Vec3 target = d.designed_positions[skin.nodes[i]];
    spec.socket_node_displacements[k] = target - shell.nodes[k];
    spec.socket_node_displacements[ni + k] =
        target + o.socket_thickness_m * d.skin_normals[i].normalized() - shell.nodes[ni + k];
  }
  return shell;
}

/// Load mode: the designed pressure as nodal forces on the skin.
void add_designed_loads(const DesignedStump& d, DeckSpec& spec) {
  const auto& skin = *d.skin;
  for (size_t i = 0; i < skin.nodes.size(); ++i)
    if (d.pressure_pa[i] > 0)
      spec.nodal_forces.push_back({skin.nodes[i], -d.pressure_pa[i] * d.skin_areas_m2[i] * d.skin_normals[i]});
}

/// The blocks of the increment compared (null where absent): displacements, contact and the
/// integration-point stresses.
struct ComparedIncrement {
  const DatBlock* gauss = nullptr;
  const FrdBlock* disp = nullptr;
  const FrdBlock* cont = nullptr;
  double time = 0;  ///< total time (the .dat's when it has the increment)
};

/// The .frd's block @p name nearest total time @p time, within the .frd's six digits; null if none.
const FrdBlock* frd_block_at(const FrdResults& frd, std::string_view name, double time) {
  const FrdBlock* best = nullptr;
  for (const auto& b : frd.blocks)
    if (b.name == name && std::abs(b.time - time) <= 1e-5 * std::max(1.0, std::abs(time)) &&
        (!best || std::abs(b.time - time) < std::abs(best->time - time)))
      best = &b;
  return best;
}

/// The increment at total time @p time; NaN: the .frd's last, unless the .dat's element stresses
/// (printed at converged increments only) end earlier — when ccx gives up it writes its last,
/// unconverged state to the .frd — then the last increment both files have.
/// @throws SolverError when there is none (or, with @p contact, it has no contact block).
ComparedIncrement compared_increment(const FrdResults& frd, const std::vector<DatBlock>& dat, bool contact,
                                     const std::string& ccx_message,
                                     double time = std::numeric_limits<double>::quiet_NaN()) {
  ComparedIncrement inc;
  if (std::isnan(time)) {
    inc.gauss = contact ? last_block(dat, "stresses", "SKINEL") : nullptr;
    inc.disp = frd.last("DISP");
    if (inc.gauss && inc.disp && !frd_block_at(frd, "DISP", inc.gauss->time)) inc.gauss = nullptr;
    if (inc.gauss) inc.disp = frd_block_at(frd, "DISP", inc.gauss->time);
  } else {
    inc.gauss = contact ? block_at(dat, "stresses", "SKINEL", time) : nullptr;
    inc.disp = frd_block_at(frd, "DISP", time);
  }
  if (contact && inc.disp)
    for (const auto& b : frd.blocks)
      if (b.name == "CONTACT" && b.step == inc.disp->step && b.increment == inc.disp->increment) inc.cont = &b;
  if (!inc.disp || (contact && !inc.cont))
    fail<SolverError>("validate design: CalculiX produced no converged increment{}: {}",
                      std::isnan(time) ? "" : fmt::format(" at time {:.4f}", time), ccx_message);
  inc.time = inc.gauss ? inc.gauss->time : inc.disp->time;
  return inc;
}

/// The FE pressure on the deformed skin by the two stress-based measures: −n·σ·n from the stress
/// of the same increment as the displacements, and the nodal-force pressure from the
/// integration-point stresses of the last printed one; each is left empty when its data is absent.
void fe_stress_pressures(const DesignedStump& d, const std::vector<HexFace>& skin_faces, const FrdResults& frd,
                         const ComparedIncrement& inc, DesignCheckResult& res) {
  const auto& mesh = *d.mesh;
  const auto& skin = *d.skin;
  const int nn = mesh.num_nodes();
  const FrdBlock* stress = nullptr;
  for (const auto& b : frd.blocks)
    if (b.name == "STRESS" && b.step == inc.disp->step && b.increment == inc.disp->increment) stress = &b;
  std::vector<Vec3> deformed(nn);
  for (int k = 0; k < nn; ++k) deformed[k] = mesh.nodes[k] + res.fe_displacement_m[k];
  std::vector<double> areas;
  const auto normals = deformed_surface_normals(mesh, deformed, skin_faces, skin.nodes, &areas);
  if (stress) res.fe_stress_pressure_pa = normal_surface_pressure(*stress, skin.nodes, normals, nn);
  if (!inc.gauss) return;
  std::vector<Vec3> force;
  res.fe_force_pressure_pa = nodal_force_pressure(mesh, deformed, *inc.gauss, skin.nodes, normals, areas, &force);
  const Vec3 axis = d.frame.axis.normalized();
  res.fe_axial_force_n = res.fe_axial_friction_n = 0;
  for (size_t k = 0; k < force.size(); ++k) {
    res.fe_axial_force_n += force[k].dot(axis);
    res.fe_axial_friction_n += (force[k] - force[k].dot(normals[k]) * normals[k]).dot(axis);
  }
}

/// Contact modes: the FE contact pressure by the chosen measure against the designed pressure,
/// the penetration, and the total contact force.
void compare_contact_pressures(const DesignedStump& d, const DesignCheckOptions& o,
                               const std::vector<HexFace>& skin_faces, const FrdResults& frd,
                               const std::vector<DatBlock>& dat, const ComparedIncrement& inc, DesignCheckResult& res) {
  const auto& skin = *d.skin;
  const int ns = static_cast<int>(skin.nodes.size()), nn = d.mesh->num_nodes();
  res.fe_pressure = o.fe_pressure;
  const auto cp = inc.cont->dense("CPRESS", nn), copen = inc.cont->dense("COPEN", nn);
  res.fe_cpress_pa.assign(ns, 0.0);
  for (int i = 0; i < ns; ++i) res.fe_cpress_pa[i] = cp[skin.nodes[i]];
  fe_stress_pressures(d, skin_faces, frd, inc, res);
  require<SolverError>(res.fe_pressure != FePressure::SurfaceStress || !res.fe_stress_pressure_pa.empty(),
                       "validate design: the .frd has no stress (S) for the last increment, so the contact "
                       "pressure −n·σ·n cannot be computed");
  require<SolverError>(res.fe_pressure != FePressure::NodalForce || !res.fe_force_pressure_pa.empty(),
                       "validate design: the .dat has no integration-point stresses (set SKINEL) for the last "
                       "increment, so the nodal-force pressure cannot be computed (use --fe-pressure stress)");
  const auto& fe_p = res.fe_pressure == FePressure::SurfaceStress ? res.fe_stress_pressure_pa
                     : res.fe_pressure == FePressure::NodalForce  ? res.fe_force_pressure_pa
                                                                  : res.fe_cpress_pa;
  for (int i = 0; i < ns; ++i) {
    res.socketsmith_value[i] = d.pressure_pa[i];
    res.fe_value[i] = fe_p[i];
    res.fe_penetration_m[i] = std::max(0.0, -copen[skin.nodes[i]]);
    res.max_penetration_m = std::max(res.max_penetration_m, res.fe_penetration_m[i]);
  }
  const DatBlock* st = inc.gauss ? block_at(dat, "statistics", "SLIMB", inc.time) : last_block(dat, "statistics", "SLIMB");
  if (st && !st->rows.empty() && st->rows[0].size() >= 3) res.fe_force_n = Vec3(st->rows[0][0], st->rows[0][1], st->rows[0][2]).norm();
}

/// Load mode: the FE displacement of the skin against the designed one, and the force on the bones.
void compare_displacements(const DesignedStump& d, const std::vector<DatBlock>& dat, DesignCheckResult& res) {
  const auto& mesh = *d.mesh;
  const auto& skin = *d.skin;
  for (size_t i = 0; i < skin.nodes.size(); ++i) {
    const int v = skin.nodes[i];
    res.socketsmith_value[i] = (d.designed_positions[v] - mesh.nodes[v]).norm();
    res.fe_value[i] = res.fe_displacement_m[v].norm();
  }
  if (const auto* st = last_block(dat, "total force", "BONE"); st && !st->rows.empty() && st->rows[0].size() >= 3)
    res.fe_force_n = Vec3(st->rows[0][0], st->rows[0][1], st->rows[0][2]).norm();
}

/// The comparisons over regions by rings from the brim (all below it, from the 2nd ring, from the
/// 4th), raw and smoothed over one ring of neighbours @p adj.
void compare_regions(const volume::SkinSurface& skin, const std::vector<std::vector<int>>& adj, bool contact,
                     DesignCheckResult& res) {
  const int ns = static_cast<int>(skin.nodes.size());
  std::vector<int> all, ring2, ring4;
  for (int i = 0; i < ns; ++i) {
    if (res.brim_ring[i] >= 1) all.push_back(i);
    if (res.brim_ring[i] >= 2) ring2.push_back(i);
    if (res.brim_ring[i] >= 4) ring4.push_back(i);
  }
  res.all = report::compare_fields(res.fe_value, res.socketsmith_value, all);
  if (contact) {
    res.all_cpress = report::compare_fields(res.fe_cpress_pa, res.socketsmith_value, all);
    if (!res.fe_stress_pressure_pa.empty())
      res.all_stress = report::compare_fields(res.fe_stress_pressure_pa, res.socketsmith_value, all);
    if (!res.fe_force_pressure_pa.empty())
      res.all_force = report::compare_fields(res.fe_force_pressure_pa, res.socketsmith_value, all);
  }
  res.one_ring_away = report::compare_fields(res.fe_value, res.socketsmith_value, ring2);
  res.away_from_brim = report::compare_fields(res.fe_value, res.socketsmith_value, ring4);
  res.fe_value_smoothed = smooth_one_ring(res.fe_value, adj, skin.area_m2);
  res.socketsmith_value_smoothed = smooth_one_ring(res.socketsmith_value, adj, skin.area_m2);
  res.all_smoothed = report::compare_fields(res.fe_value_smoothed, res.socketsmith_value_smoothed, all);
  res.away_from_brim_smoothed = report::compare_fields(res.fe_value_smoothed, res.socketsmith_value_smoothed, ring4);
  res.mean_fe_pa = res.all.mean_a;
  res.mean_designed_pa = res.all.mean_b;
}

/// The thesis's paths, sampled on the rest skin as in the design report (nodes above the brim
/// left out); s in mm along a vertical path, in degrees around a horizontal one.
void compare_paths(const DesignedStump& d, DesignCheckResult& res) {
  const auto& skin = *d.skin;
  const auto sframe = report::surface_frame(d.frame);
  for (const auto& path : report::thesis_paths(d.front_theta_rad, 0.5 * d.stump_length_m, skin.area_m2)) {
    PathComparison pc;
    pc.name = path.key;
    pc.label = path.label;
    pc.is_vertical = path.spec.kind == report::PathKind::Vertical;
    for (const auto& smp : report::sample_path(skin.positions, {}, sframe, path.spec)) {
      if (res.brim_ring[smp.index] < 1) continue;
      pc.skin_index.push_back(smp.index);
      pc.s.push_back(pc.is_vertical ? smp.s * 1e3 : smp.s * 180 / std::numbers::pi);
    }
    pc.stats = report::compare_fields(res.fe_value, res.socketsmith_value, pc.skin_index);
    pc.smoothed = report::compare_fields(res.fe_value_smoothed, res.socketsmith_value_smoothed, pc.skin_index);
    res.paths.push_back(std::move(pc));
  }
}

/// Halves the steps' increments (not below the smallest), the first as the largest.
void halve_increments(FeSteps& st) {
  st.initial_increment = std::max(0.5 * st.initial_increment, st.min_increment);
  st.max_increment = st.initial_increment;
}

/// Renames ccx's log @p log to <stem>.<what>.log, so that the next run does not overwrite it; the
/// name it now has (the old one when it could not be renamed).
std::filesystem::path keep_log(const std::filesystem::path& log, const std::string& what) {
  if (log.empty() || !std::filesystem::exists(log)) return log;
  std::filesystem::path kept = log;
  kept.replace_extension("." + what + ".log");
  std::error_code ec;
  std::filesystem::rename(log, kept, ec);
  return ec ? log : kept;
}

/// ccx stopped inside step 1 after solving some increments (not a rejected deck, a time limit or a
/// cancel): a contact caught deep in one increment, which shorter increments avoid.
bool stopped_in_first_step(const CcxRun& run) {
  return !run.converged && !run.timed_out && !run.cancelled && run.increments > 0 && run.last_step <= 1 &&
         run.last_step_time < 1.0 - 1e-9;
}

/// Writes and runs the deck. Step 1 stopped on its way is run once more with increments half as
/// long (OpenLimb's mean transtibial limb at 3k: ccx's factorisation gave up at 25 % of the donning
/// with increments of 5 %, and went through with 2.5 %). A standing step that ended short of the
/// load, or pushed the wrong way (CalculiX's donned socket carried more, or less, than
/// socketsmith's), is run again with the travel CalculiX's own reactions ask for
/// (standing_retry_travel_m), twice at most: a first push the wrong way measures the unloading
/// stiffness (friction reversed), too stiff to extrapolate the loading from.
/// The last run's .dat is returned in @p dat and, with a standing step, its standing pose in @p pose.
CcxOptions run_deck(DeckSpec& spec, double stand_force_n, const std::filesystem::path& dir, const std::string& job,
                    const CcxOptions& ccx, DesignCheckResult& res, std::vector<DatBlock>& dat, StandingPose& pose) {
  CcxOptions co = ccx;
  co.num_steps = spec.steps.stand_travel_m != 0 ? 2 : 1;
  const auto run = [&] {
    write_text_atomically(res.deck, write_deck(spec));
    res.ccx = run_ccx(dir, job, co);
    ++res.ccx_runs;
    res.ccx_total_wall_s += res.ccx.wall_s;
    dat = std::filesystem::exists(res.ccx.dat) ? read_dat(res.ccx.dat) : std::vector<DatBlock>{};
    pose = co.num_steps == 2 ? standing_pose(dat, stand_force_n, spec.steps.load_direction) : StandingPose{};
  };
  run();
  if (stopped_in_first_step(res.ccx)) {
    halve_increments(spec.steps);
    // The stopped run's log is kept beside the retry's (the message names it; the retry would
    // overwrite it).
    const auto kept = keep_log(res.ccx.log, "stopped");
    log::info("validate: CalculiX stopped at {:.0f} % of step 1 ({}; its log kept as {}); again with increments of "
              "{:.1f} %",
              100 * res.ccx.last_step_time, res.ccx.message, kept.string(), 100 * spec.steps.initial_increment);
    run();
  }
  res.stand_travel_m = spec.steps.stand_travel_m;
  for (int pass = 0; pass < 2 && co.num_steps == 2 && !pose.reached; ++pass) {
    const double retry = standing_retry_travel_m(pose, spec.steps.stand_travel_m, stand_force_n);
    if (!std::isfinite(retry)) break;
    log::info("validate: CalculiX's socket carried {:.0f} N donned and {:.0f} N {:+.2f} mm past that pose, not the "
              "standing {:.0f} N; standing again with a push of {:+.2f} mm",
              pose.donned_force_n, pose.last_force_n, pose.last_displacement_m * 1e3, stand_force_n, retry * 1e3);
    spec.steps.stand_travel_m = retry;
    run();
    res.stand_travel_m = retry;
  }
  res.converged = res.ccx.converged;
  res.message = res.ccx.message;
  return co;
}

/// The fields CalculiX gives at increment @p inc, into @p res: displacements and the compared
/// quantity (contact pressures or, Load mode, displacements).
void read_increment(const DesignedStump& d, const DesignCheckOptions& o, const DeckSpec& spec, const FrdResults& frd,
                    const std::vector<DatBlock>& dat, const ComparedIncrement& inc, DesignCheckResult& res) {
  const int nn = d.mesh->num_nodes(), ns = static_cast<int>(d.skin->nodes.size());
  const auto u1 = inc.disp->dense("D1", nn), u2 = inc.disp->dense("D2", nn), u3 = inc.disp->dense("D3", nn);
  res.fe_displacement_m.resize(nn);
  for (int k = 0; k < nn; ++k) res.fe_displacement_m[k] = Vec3(u1[k], u2[k], u3[k]);
  res.socketsmith_value.assign(ns, 0.0);
  res.fe_value.assign(ns, 0.0);
  res.fe_penetration_m.assign(ns, 0.0);
  if (o.mode != DesignCheckMode::Load)
    compare_contact_pressures(d, o, spec.skin_faces, frd, dat, inc, res);
  else
    compare_displacements(d, dat, res);
}

/// @p a ← (1 − w) a + w b over the fields read_increment reads (a field one of them lacks is dropped).
void interpolate_increments(DesignCheckResult& a, const DesignCheckResult& b, double w) {
  const auto lerp = [w](auto& x, const auto& y) {
    if (x.size() != y.size()) {
      x.clear();
      return;
    }
    for (size_t i = 0; i < x.size(); ++i) x[i] = (1 - w) * x[i] + w * y[i];
  };
  lerp(a.fe_displacement_m, b.fe_displacement_m);
  lerp(a.fe_value, b.fe_value);
  lerp(a.fe_penetration_m, b.fe_penetration_m);
  lerp(a.fe_cpress_pa, b.fe_cpress_pa);
  lerp(a.fe_stress_pressure_pa, b.fe_stress_pressure_pa);
  lerp(a.fe_force_pressure_pa, b.fe_force_pressure_pa);
  for (auto [x, y] : {std::pair{&a.fe_force_n, b.fe_force_n}, std::pair{&a.fe_axial_force_n, b.fe_axial_force_n},
                       std::pair{&a.fe_axial_friction_n, b.fe_axial_friction_n}})
    *x = (1 - w) * *x + w * y;
  a.max_penetration_m = a.fe_penetration_m.empty() ? 0.0 : *std::max_element(a.fe_penetration_m.begin(), a.fe_penetration_m.end());
}

/// Runs the deck (run_deck) and compares CalculiX's increment with the design into @p res: at
/// CalculiX's standing load when it stood, else at its last converged increment; then where its
/// compared pressure alternates node by node.
void run_and_compare(const DesignedStump& d, const DesignCheckOptions& o, DeckSpec& spec,
                     const std::vector<std::vector<int>>& adj, const std::filesystem::path& dir, const std::string& job,
                     DesignCheckResult& res) {
  const auto& skin = *d.skin;
  const bool contact = o.mode != DesignCheckMode::Load;
  std::vector<DatBlock> dat;
  StandingPose pose;
  const CcxOptions co = run_deck(spec, o.stand_force_n, dir, job, o.ccx, res, dat, pose);

  FrdResults frd;
  if (std::filesystem::exists(res.ccx.frd)) frd = read_frd(res.ccx.frd);
  if (pose.reached) {
    // CalculiX standing: between the two increments whose reactions bracket the load.
    read_increment(d, o, spec, frd, dat, compared_increment(frd, dat, contact, res.ccx.message, pose.time_a), res);
    DesignCheckResult b;
    read_increment(d, o, spec, frd, dat, compared_increment(frd, dat, contact, res.ccx.message, pose.time_b), b);
    interpolate_increments(res, b, pose.weight);
    res.stood = true;
    res.stand_offset_m = pose.displacement_m;
    res.stand_reached_force_n = o.stand_force_n;
    if (!res.converged)
      res.message = fmt::format("stood at {:.0f} N {:+.2f} mm past the designed pose; ccx stopped beyond it (time {:.3f} of 2): {}",
                                o.stand_force_n, pose.displacement_m * 1e3, pose.last_time, res.ccx.message);
    res.converged = true;
  } else {
    const ComparedIncrement inc = compared_increment(frd, dat, contact, res.ccx.message);
    if (!res.converged)
      res.message = fmt::format("PARTIAL results (step {}, time {:.3f} of {}): {}", inc.disp->step, inc.disp->time,
                                co.num_steps, res.ccx.message);
    else if (co.num_steps == 2) {
      res.converged = false;
      res.message = fmt::format("PARTIAL results: CalculiX's socket carries {:.0f} N at its furthest pose ({:+.2f} mm "
                                "past the designed pose), not the standing {:.0f} N (donned: {:.0f} N)",
                                pose.last_force_n, pose.last_displacement_m * 1e3, o.stand_force_n, pose.donned_force_n);
    }
    read_increment(d, o, spec, frd, dat, inc, res);
  }
  if (co.num_steps == 2) {
    res.donned_force_n = pose.donned_force_n;
    if (!pose.reached) {
      res.stand_offset_m = pose.last_displacement_m;
      res.stand_reached_force_n = pose.last_force_n;
    }
  }
  compare_regions(skin, adj, contact, res);
  compare_paths(d, res);
  if (!contact) return;
  res.fe_alternating = alternating_skin_nodes(res.fe_value, res.socketsmith_value, adj, res.brim_ring,
                                              o.alternation_margin_pa);
  res.fe_alternating_nodes =
      static_cast<int>(std::count(res.fe_alternating.begin(), res.fe_alternating.end(), char{1}));
}

}  // namespace

constexpr EnumName<DesignCheckMode> kCheckModes[] = {
    {DesignCheckMode::Contact, "contact"}, {DesignCheckMode::Load, "load"}, {DesignCheckMode::Donning, "donning"}};
constexpr EnumName<FePressure> kFePressures[] = {
    {FePressure::NodalForce, "force"}, {FePressure::SurfaceStress, "stress"}, {FePressure::Cpress, "cpress"}};

std::string to_string(DesignCheckMode mode) { return name_of(kCheckModes, mode, "contact"); }

DesignCheckMode parse_design_check_mode(const std::string& text) {
  return parse_named(kCheckModes, text, "FE check mode '{}' is not known (expected contact, load or donning)");
}

std::string to_string(FePressure what) { return name_of(kFePressures, what, "force"); }

FePressure parse_fe_pressure(const std::string& text) {
  return parse_named(kFePressures, text, "FE pressure '{}' is not known (expected force, stress or cpress)");
}

DesignCheckResult check_design(const DesignedStump& d, const DesignCheckOptions& o, const std::filesystem::path& dir,
                               const std::string& job) {
  check_input(d, o);
  find_ccx(o.ccx.executable);
  const auto& mesh = *d.mesh;
  const auto& skin = *d.skin;
  const int ns = static_cast<int>(skin.nodes.size());
  std::vector<int> skin_of(mesh.nodes.size(), -1);
  for (int i = 0; i < ns; ++i) skin_of[skin.nodes[i]] = i;

  DesignCheckResult res;
  res.mode = o.mode;
  res.nodes = mesh.num_nodes();
  res.elements = mesh.num_hexahedra();
  const auto adj = skin.neighbours();
  res.brim_ring = brim_rings(adj, d.above_brim);
  Vec3 f_design = Vec3::Zero();
  for (int i = 0; i < ns; ++i) f_design += d.pressure_pa[i] * d.skin_areas_m2[i] * d.skin_normals[i];
  res.designed_force_n = f_design.norm();

  DeckSpec spec = base_deck(d, o);
  RigidShell shell;
  const bool contact = o.mode != DesignCheckMode::Load;
  if (contact) {
    const bool to_lip = o.mode == DesignCheckMode::Donning && o.shell_lip;
    const auto socket_quads = socket_quads_below_brim(d, skin_of, to_lip);
    shell = o.mode == DesignCheckMode::Donning ? donning_socket(d, o, socket_quads, spec)
                                               : contact_socket(d, o, socket_quads, spec);
    spec.socket = &shell;
    spec.skin_faces = faces_of_quads(mesh, skin.quads);
    res.socket_elements = static_cast<int>(shell.hexahedra.size());
  } else {
    add_designed_loads(d, spec);
  }
  ensure_directory(dir);
  res.deck = dir / (job + ".inp");
  const DesignCheckResult header = res;
  const auto alternates = [&] {
    return contact && o.alternation_rerun_nodes > 0 && res.fe_alternating_nodes >= o.alternation_rerun_nodes;
  };
  run_and_compare(d, o, spec, adj, dir, job, res);
  if (alternates() && spec.steps.initial_increment > spec.steps.min_increment) {
    const double was = spec.steps.initial_increment;
    halve_increments(spec.steps);
    const auto kept = keep_log(res.ccx.log, "alternating");
    log::info("validate: CalculiX's pressure alternates node by node at {} skin nodes below the brim with increments "
              "of {:.1f} % (its log kept as {}); again with {:.2f} %",
              res.fe_alternating_nodes, 100 * was, kept.string(), 100 * spec.steps.initial_increment);
    // Compared afresh; the first try's runs, time and count carried over.
    DesignCheckResult again = header;
    again.ccx_runs = res.ccx_runs;
    again.ccx_total_wall_s = res.ccx_total_wall_s;
    again.fe_alternating_nodes_first_try = res.fe_alternating_nodes;
    res = std::move(again);
    run_and_compare(d, o, spec, adj, dir, job, res);
  }
  if (alternates())
    log::warn("validate: CalculiX's pressure alternates node by node at {} skin nodes below the brim (increments of "
              "{:.2f} %): read its peaks there with caution, or rerun with a smaller --initial-increment",
              res.fe_alternating_nodes, 100 * spec.steps.initial_increment);
  return res;
}

}  // namespace socketsmith::calculix
