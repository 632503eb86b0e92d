#include "socketsmith/pipeline/sock_ply.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>

#include <Eigen/SparseCholesky>
#include <Eigen/SparseCore>

#include "socketsmith/core/errors.h"
#include "socketsmith/core/log.h"
#include "socketsmith/core/units.h"
#include "socketsmith/pipeline/design_pipeline.h"
#include "socketsmith/report/csv.h"
#include "socketsmith/report/plot_raster.h"
#include "socketsmith/report/svg_plot.h"
#include "socketsmith/tissue/pressure_load.h"
#include "socketsmith/volume/hex_element.h"

namespace socketsmith::pipeline {
namespace {

using Vec3 = Eigen::Vector3d;
using Clock = std::chrono::steady_clock;
double since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

std::vector<Vec3> moved_nodes(const volume::HexMesh& mesh, const std::vector<Vec3>& field, double d) {
  std::vector<Vec3> x = mesh.nodes;
  for (size_t k = 0; k < x.size(); ++k) x[k] += d * field[k];
  return x;
}

/// "−4 %", "+2 %", "as designed".
std::string level_name(double f) {
  return f == 0 ? std::string("as designed") : fmt::format("{:+.3g} %", 100 * f);
}

/// "all hold", or each failing condition with its value and what it should be:
/// "F_x −28.3 N (0 ± 3.4), comfort: peak p/T 1.12".
std::string constraint_text(const SockPlyLevel& l, const design::RadarTargets& t) {
  if (l.status.all_ok()) return "all hold";
  std::string out;
  const auto add = [&](const std::string& s) { out += (out.empty() ? "" : ", ") + s; };
  const char* axes[] = {"x", "y", "z"};
  for (int a = 0; a < 3; ++a)
    if (!l.status.force_ok[a])
      add(fmt::format("F_{} {:.1f} N ({:.0f} ± {:.1f})", axes[a], l.radar.force_n[a], a == 2 ? t.fz_n : 0.0,
                      t.force_tol_n));
  for (int a = 0; a < 3; ++a)
    if (!l.status.torque_ok[a])
      add(fmt::format("T_{} {:.2f} N·m (0 ± {:.2f})", axes[a], l.radar.torque_nm[a], t.torque_tol_nm));
  if (!l.status.stability_ok) add(fmt::format("stability {:.0f} N (≥ {:.0f})", l.radar.stability_n, t.stability_min_n));
  if (!l.status.comfort_ok) add(fmt::format("comfort: peak p/T {:.2f}", l.peak_ratio));
  return "fail: " + out;
}

}  // namespace

std::vector<Vec3> skin_offset_field(const volume::HexMesh& mesh, const volume::SkinSurface& skin) {
  const int n = mesh.num_nodes();
  require(skin.normal.size() == skin.nodes.size(), "skin_offset_field: {} skin normals for {} skin nodes",
          skin.normal.size(), skin.nodes.size());
  // Dirichlet values: the free skin nodes move along their normal, the fixed nodes stay.
  std::vector<char> known(n, 0);
  std::vector<Vec3> u(n, Vec3::Zero());
  for (int k = 0; k < n; ++k)
    if (mesh.has_tag(k, volume::kNodeFixed)) known[k] = 1;
  for (size_t i = 0; i < skin.nodes.size(); ++i) {
    const int k = skin.nodes[i];
    require(k >= 0 && k < n, "skin_offset_field: skin node {} is not a node of the {}-node mesh", k, n);
    require(skin.normal[i].allFinite() && std::abs(skin.normal[i].norm() - 1) < 1e-6,
            "skin_offset_field: the normal of skin node {} is not a unit vector", k);
    if (known[k]) continue;  // a fixed skin node (the proximal rim) stays
    known[k] = 1;
    u[k] = skin.normal[i];
  }
  // Unknowns: the other nodes. Graph Laplacian over every pair of nodes sharing a hexahedron.
  std::vector<int> index(n, -1);
  int m = 0;
  for (int k = 0; k < n; ++k)
    if (!known[k]) index[k] = m++;
  if (m == 0) return u;
  std::vector<Eigen::Triplet<double>> trip;
  Eigen::MatrixXd rhs = Eigen::MatrixXd::Zero(m, 3);
  for (const auto& h : mesh.hexahedra)
    for (int a = 0; a < 8; ++a)
      for (int b = 0; b < 8; ++b) {
        if (a == b) continue;
        const int i = h[a], j = h[b];
        if (index[i] < 0) continue;
        trip.emplace_back(index[i], index[i], 1.0);
        if (index[j] >= 0)
          trip.emplace_back(index[i], index[j], -1.0);
        else
          rhs.row(index[i]) += u[j].transpose();
      }
  Eigen::SparseMatrix<double> L(m, m);
  L.setFromTriplets(trip.begin(), trip.end());
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> ldlt(L);
  require<SolverError>(ldlt.info() == Eigen::Success,
                       "skin_offset_field: the stump's interior is not connected to its skin or bones (the Laplacian "
                       "is singular)");
  const Eigen::MatrixXd x = ldlt.solve(rhs);
  for (int k = 0; k < n; ++k)
    if (index[k] >= 0) u[k] = x.row(index[k]).transpose();
  return u;
}

double offset_volume(const volume::HexMesh& mesh, const std::vector<Vec3>& field, double offset_m) {
  require(field.size() == mesh.nodes.size(), "offset_volume: {} field vectors for {} nodes", field.size(),
          mesh.nodes.size());
  const std::vector<Vec3> x = moved_nodes(mesh, field, offset_m);
  double v = 0;
  for (const auto& h : mesh.hexahedra) v += volume::hex_volume(volume::gather(x, h));
  return v;
}

double offset_for_volume_change(const volume::HexMesh& mesh, const std::vector<Vec3>& field, double volume_change) {
  require(std::isfinite(volume_change) && std::abs(volume_change) <= 0.2,
          "sock ply: a volume change of {} % is outside [-20, 20] %", 100 * volume_change);
  if (volume_change == 0) return 0.0;
  const double v0 = offset_volume(mesh, field, 0.0);
  const auto residual = [&](double d) { return offset_volume(mesh, field, d) / v0 - 1.0 - volume_change; };
  // V(d) is a cubic in d with V'(0) ≈ the skin's area: the first step is d = ΔV / V'(0), then secants.
  const double h = 1e-5;
  const double slope = (offset_volume(mesh, field, h) - offset_volume(mesh, field, -h)) / (2 * h) / v0;
  require(slope > 0, "sock ply: the stump's volume does not grow with the skin's offset (is the skin inside out?)");
  double d0 = 0, r0 = -volume_change, d1 = volume_change / slope, r1 = residual(d1);
  for (int it = 0; it < 50 && std::abs(r1) > 1e-9; ++it) {
    const double d2 = d1 - r1 * (d1 - d0) / (r1 - r0);
    d0 = d1;
    r0 = r1;
    d1 = d2;
    r1 = residual(d1);
  }
  require(std::abs(r1) <= 1e-6, "sock ply: no uniform skin offset changes the stump's volume by {} %",
          100 * volume_change);
  const std::vector<Vec3> x = moved_nodes(mesh, field, d1);
  double worst = std::numeric_limits<double>::infinity();
  for (const auto& hex : mesh.hexahedra) worst = std::min(worst, volume::min_corner_jacobian(volume::gather(x, hex)));
  require(worst > 0, "sock ply: a skin offset of {:.2f} mm ({:+.1f} % of the volume) inverts elements of the stump; "
                     "ask for a smaller volume change",
          d1 * 1e3, 100 * volume_change);
  return d1;
}

namespace {

/// The volume changes studied: the asked ones (each within ±20 %) and 0, ascending, duplicates
/// dropped. Refuses a design without a socket and a distal fraction out of range.
std::vector<double> study_levels(const DesignResult& result, const SockPlyOptions& options) {
  require(result.socket.has_value() && result.constraints_met,
          "sock ply: the design does not meet its constraints, so it has no socket to don; fix the design first");
  require(std::isfinite(options.distal_fraction) && options.distal_fraction > 0 && options.distal_fraction <= 1,
          "sock ply: distal fraction {} is outside (0, 1]", options.distal_fraction);
  std::vector<double> changes = options.volume_changes;
  for (double f : changes)
    require(std::isfinite(f) && std::abs(f) <= 0.2,
            "sock ply: a volume change of {} % is outside [-20, 20] % (e.g. -4, -2, 2, 4)", 100 * f);
  changes.push_back(0.0);
  std::sort(changes.begin(), changes.end());
  changes.erase(std::unique(changes.begin(), changes.end(), [](double a, double b) { return std::abs(a - b) < 1e-12; }),
                changes.end());
  return changes;
}

/// What every level of the study shares: the design, the skin offset field, the stump's volume,
/// the skin nodes compared and the donning's options.
struct SockPlyStudy {
  DesignSetup& setup;
  const DesignResult& result;
  const SockPlyOptions& options;
  std::vector<Vec3> field;          ///< skin_offset_field of the stump
  double stump_volume_m3 = 0.0;     ///< at rest [m³]
  std::vector<char> distal;         ///< skin nodes below the brim within distal_fraction of the length
  contact::DonningOptions don;      ///< the loads and the body of the closed loop's donning
};

/// The study's donning: the patient's friction and half the body weight unless kept as given;
/// the donned body as the closed loop's, linearised at rest for a linear design.
contact::DonningOptions study_donning(const DesignSetup& setup, const DesignResult& result,
                                      const SockPlyOptions& options) {
  const design::CaseFile& c = setup.case_file;
  contact::DonningOptions don = options.donning;
  if (!options.keep_donning_loads) {
    don.friction = c.patient.friction;
    don.stand_force_n = 0.5 * c.patient.body_mass_kg * units::kGravity;
  }
  // The donned body as the closed loop's: linearised at rest for a linear design.
  don.contact.linear_body = design_body_linearised(result.state, c);
  don.skin = &setup.solver->skin();  // pressures per deformed area, as the design's
  return don;
}

/// Skin nodes compared: below the brim; the distal end: those within distal_fraction of the length.
std::vector<char> distal_nodes(const DesignSetup& setup, double distal_fraction) {
  const auto& skin = setup.solver->skin();
  const auto& above = setup.solver->above_brim();
  const auto& frame = setup.model.frame;
  const Vec3 axis = frame.axis.normalized();
  const size_t ns = skin.nodes.size();
  std::vector<char> distal(ns, 0);
  for (size_t i = 0; i < ns; ++i)
    distal[i] = !above[i] && (skin.positions[i] - frame.origin).dot(axis) <= distal_fraction * setup.model.length_m;
  return distal;
}

/// The designed socket donned and stood on the changed limb @p model. A failed solve, and a
/// changed limb the socket cannot start below, give a donning not completed.
contact::DonningResult don_changed_limb(const SockPlyStudy& st, const tissue::MassSpringModel& model,
                                        const std::vector<double>& rest_area, const contact::DonningOptions& don,
                                        double volume_change) {
  contact::DonningResult d;
  try {
    contact::DonningSimulation sim(model, st.setup.solver->skin().nodes, rest_area, st.result.socket->solid,
                                   st.setup.model.frame, don);
    d = sim.run();
  } catch (const SolverError& e) {
    d.completed = false;
    d.message = e.what();
  } catch (const InvalidInputError& e) {
    // A changed limb the socket cannot start below (it grips already): that level is reported as
    // not donned; at the designed volume it is the design's problem and goes up.
    if (volume_change == 0) throw;
    d.completed = false;
    d.message = e.what();
  }
  return d;
}

/// The donning's outcome into @p lv: completed, stood, where, the last step and the pressures.
void record_donning(const contact::DonningResult& d, size_t ns, SockPlyLevel& lv) {
  lv.completed = d.completed;
  lv.stood = d.completed && d.stood;
  lv.message = d.message;
  lv.seconds = d.seconds;
  lv.factorizations = d.series.empty() ? 0 : static_cast<int>(d.series.back().factorizations);
  lv.stood_offset_m = d.final_offset_m;
  if (!d.series.empty()) {
    lv.contact_nodes = d.series.back().contact_nodes;
    lv.axial_force_n = d.series.back().axial_force_n;
  }
  lv.pressure_pa.assign(ns, 0.0);
  if (d.contacts.size() == ns)
    for (size_t i = 0; i < ns; ++i) lv.pressure_pa[i] = d.contacts[i].pressure_pa;
}

/// Peak, peak ratio (and the landmark nearest it), distal pressure: below the brim.
void measure_peaks(const SockPlyStudy& st, SockPlyLevel& lv) {
  const auto& skin = st.setup.solver->skin();
  const auto& above = st.setup.solver->above_brim();
  int peak_node = -1;
  double dw = 0, dsum = 0;
  for (size_t i = 0; i < skin.nodes.size(); ++i) {
    if (above[i]) continue;
    const double p = lv.pressure_pa[i];
    lv.peak_pressure_pa = std::max(lv.peak_pressure_pa, p);
    const double ratio = p / st.setup.thresholds[i];
    if (ratio > lv.peak_ratio) {
      lv.peak_ratio = ratio;
      peak_node = static_cast<int>(i);
    }
    if (st.distal[i]) {
      dsum += p * skin.area_m2[i];
      dw += skin.area_m2[i];
      lv.distal_peak_pa = std::max(lv.distal_peak_pa, p);
    }
  }
  lv.distal_mean_pa = dw > 0 ? dsum / dw : 0.0;
  if (peak_node >= 0) {
    double best = std::numeric_limits<double>::infinity();
    for (const auto& lm : st.setup.model.landmarks) {
      const double dist = (lm.position - skin.positions[peak_node]).norm();
      if (dist < best) {
        best = dist;
        lv.peak_zone = lm.code;
      }
    }
  }
}

/// The design's conditions on the delivered pressures, at the donned shape @p x, and the donned skin.
void check_delivered(const SockPlyStudy& st, const tissue::VectorXd& x, SockPlyLevel& lv) {
  const auto& solver = *st.setup.solver;
  const auto& skin = solver.skin();
  const auto& above = solver.above_brim();
  const size_t ns = skin.nodes.size();
  std::vector<Vec3> pos(ns), nrm;
  std::vector<double> area;
  tissue::skin_areas_and_normals(skin, x, area, nrm);
  std::vector<double> p_below(ns, 0.0);
  for (size_t i = 0; i < ns; ++i) {
    pos[i] = x.segment<3>(3 * skin.nodes[i]);
    if (!above[i]) p_below[i] = lv.pressure_pa[i];
  }
  lv.radar = design::compute_radar(pos, nrm, area, p_below, st.setup.model.frame, st.result.state.centre_of_inertia,
                                   st.setup.case_file.patient.friction);
  lv.status = design::check_constraints(lv.radar, solver.targets(), lv.peak_ratio);
  lv.donned_skin = skin.triangles();
  lv.donned_skin.vertices = pos;
}

/// Level @p l of @p nl: the limb changed by @p volume_change (a uniform skin offset), the socket
/// donned and stood on it, and what it delivers.
SockPlyLevel study_level(SockPlyStudy& st, int l, int nl, double volume_change) {
  const auto tl = Clock::now();
  const auto& mesh = st.setup.mesh.mesh;
  const auto& skin = st.setup.solver->skin();
  SockPlyLevel lv;
  lv.volume_change = volume_change;
  lv.skin_offset_m = offset_for_volume_change(mesh, st.field, lv.volume_change);
  volume::HexMesh changed = mesh;
  changed.nodes = moved_nodes(mesh, st.field, lv.skin_offset_m);
  lv.achieved_volume_change = offset_volume(mesh, st.field, lv.skin_offset_m) / st.stump_volume_m3 - 1.0;
  const tissue::MassSpringModel model(changed, st.setup.material, st.setup.model_options);
  std::vector<double> rest_area;
  std::vector<Vec3> rest_normal;
  tissue::skin_areas_and_normals(skin, model.rest_positions(), rest_area, rest_normal);
  st.don.progress = [&options = st.options, l, nl, name = level_name(lv.volume_change)](double f, std::string_view) {
    return report_progress(options.progress, (l + f) / nl, "sock ply: donning the limb " + name);
  };
  log::info("sock ply: the limb {} (skin offset {:+.3f} mm): donning", level_name(lv.volume_change),
            lv.skin_offset_m * 1e3);
  const contact::DonningResult d = don_changed_limb(st, model, rest_area, st.don, lv.volume_change);
  record_donning(d, skin.nodes.size(), lv);
  const tissue::VectorXd x = d.positions.size() == model.rest_positions().size() ? d.positions : model.rest_positions();
  measure_peaks(st, lv);
  check_delivered(st, x, lv);
  log::info("sock ply: the limb {}: {} — socket at {:+.2f} mm, peak p/T {:.3f} ({}), distal mean {:.1f} kPa; {:.1f} s",
            level_name(lv.volume_change),
            lv.stood ? "stood" : (lv.completed ? "donned, did not stand" : "not donned"), lv.stood_offset_m * 1e3,
            lv.peak_ratio, lv.peak_zone, lv.distal_mean_pa / 1e3, since(tl));
  return lv;
}

/// Each level's sink against the designed volume's standing, and the one-line summary; refused
/// when the designed volume itself did not stand.
void summarise_study(SockPlyResult& r) {
  const SockPlyLevel& ref = r.levels[r.reference];
  require<SolverError>(ref.stood, "sock ply: the designed socket could not be donned and stood on at the designed "
                                  "volume: {}",
                       ref.message.empty() ? "the standing load was not reached" : ref.message);
  for (auto& lv : r.levels) lv.sink_m = lv.stood ? lv.stood_offset_m - ref.stood_offset_m : std::nan("");
  std::string parts;
  for (const auto& lv : r.levels) {
    if (lv.volume_change == 0) continue;
    parts += (parts.empty() ? "" : "; ") +
             (lv.stood ? fmt::format("{}: {} {:.1f} mm, peak p/T {:.2f}", level_name(lv.volume_change),
                                     lv.sink_m >= 0 ? "sinks" : "rises", std::abs(lv.sink_m) * 1e3, lv.peak_ratio)
                       : fmt::format("{}: did not stand", level_name(lv.volume_change)));
  }
  r.summary = fmt::format("as designed the socket stands at {:+.2f} mm, peak p/T {:.2f}; {}", ref.stood_offset_m * 1e3,
                          ref.peak_ratio, parts);
}

}  // namespace

SockPlyResult run_sock_ply_study(DesignSetup& setup, const DesignResult& result, const SockPlyOptions& options) {
  const std::vector<double> changes = study_levels(result, options);
  const auto t0 = Clock::now();
  const auto& skin = setup.solver->skin();
  const auto& mesh = setup.mesh.mesh;
  SockPlyStudy st{setup, result, options, {}, 0.0, {}, study_donning(setup, result, options)};

  SockPlyResult r;
  r.standing_force_n = st.don.stand_force_n;
  r.friction = st.don.friction;
  st.field = skin_offset_field(mesh, skin);
  st.stump_volume_m3 = r.stump_volume_m3 = offset_volume(mesh, st.field, 0.0);
  for (size_t i = 0; i < skin.nodes.size(); ++i)
    if (!mesh.has_tag(skin.nodes[i], volume::kNodeFixed)) r.skin_area_m2 += skin.area_m2[i];
  st.distal = distal_nodes(setup, options.distal_fraction);

  const int nl = static_cast<int>(changes.size());
  for (int l = 0; l < nl; ++l) {
    if (changes[l] == 0) r.reference = l;
    r.levels.push_back(study_level(st, l, nl, changes[l]));
  }
  summarise_study(r);
  r.seconds = since(t0);
  report_progress(options.progress, 1.0, "sock ply: done");
  return r;
}

namespace {

/// sockply.csv: one row per level.
void write_levels_csv(const std::filesystem::path& out, const SockPlyResult& s) {
  report::CsvTable t;
  t.header = {"volume_change_pct", "achieved_volume_change_pct", "skin_offset_mm", "completed", "stood",
              "stood_at_mm", "sink_mm", "peak_kpa", "peak_ratio", "distal_mean_kpa", "distal_peak_kpa",
              "contact_nodes", "axial_force_n", "fx_n", "fy_n", "fz_n", "tx_nm", "ty_nm", "tz_nm", "stability_n",
              "constraints_ok", "comfort_ok", "stability_ok", "seconds"};
  for (const auto& l : s.levels)
    t.rows.push_back({100 * l.volume_change, 100 * l.achieved_volume_change, l.skin_offset_m * 1e3,
                      l.completed ? 1.0 : 0.0, l.stood ? 1.0 : 0.0, l.stood_offset_m * 1e3, l.sink_m * 1e3,
                      l.peak_pressure_pa / 1e3, l.peak_ratio, l.distal_mean_pa / 1e3, l.distal_peak_pa / 1e3,
                      static_cast<double>(l.contact_nodes), l.axial_force_n, l.radar.force_n.x(), l.radar.force_n.y(),
                      l.radar.force_n.z(), l.radar.torque_nm.x(), l.radar.torque_nm.y(), l.radar.torque_nm.z(),
                      l.radar.stability_n, l.status.all_ok() ? 1.0 : 0.0, l.status.comfort_ok ? 1.0 : 0.0,
                      l.status.stability_ok ? 1.0 : 0.0, l.seconds});
  report::write_csv(out / "sockply.csv", t.header, t.rows, 9);
}

/// sockply_nodes.csv: per skin node, the contact pressure at every level.
void write_nodes_csv(const std::filesystem::path& out, const DesignSetup& setup, const SockPlyResult& s) {
  const auto& skin = setup.solver->skin();
  const auto& above = setup.solver->above_brim();
  report::CsvTable t;
  t.header = {"x_m", "y_m", "z_m", "above_brim", "threshold_pa"};
  for (const auto& l : s.levels) t.header.push_back(fmt::format("pressure_{:+.3g}pct_pa", 100 * l.volume_change));
  for (size_t i = 0; i < skin.nodes.size(); ++i) {
    std::vector<double> row{skin.positions[i].x(), skin.positions[i].y(), skin.positions[i].z(),
                            above[i] ? 1.0 : 0.0, setup.thresholds[i]};
    for (const auto& l : s.levels) row.push_back(l.pressure_pa[i]);
    t.rows.push_back(std::move(row));
  }
  report::write_csv(out / "sockply_nodes.csv", t.header, t.rows, 9);
}

/// Plots: sink, peak ratio (with the threshold), distal pressure against the volume change, of
/// the levels that stood.
std::vector<report::Plot> study_plots(const SockPlyResult& s) {
  std::vector<report::Plot> plots(3);
  const struct {
    const char* title;
    const char* y;
    double (*value)(const SockPlyLevel&);
  } specs[] = {{"Limb sinks in the socket (> 0) or rises", "sink [mm]", [](const SockPlyLevel& l) { return l.sink_m * 1e3; }},
               {"Peak pressure / pain threshold", "peak p/T [-]", [](const SockPlyLevel& l) { return l.peak_ratio; }},
               {"Distal end: mean contact pressure", "pressure [kPa]",
                [](const SockPlyLevel& l) { return l.distal_mean_pa / 1e3; }}};
  for (int k = 0; k < 3; ++k) {
    auto& p = plots[k];
    p.title = specs[k].title;
    p.x_label = "limb volume change [%]";
    p.y_label = specs[k].y;
    p.width_px = 480;
    p.height_px = 360;
    p.legend = report::LegendPosition::None;
    report::PlotSeries ser;
    ser.markers = true;
    for (const auto& l : s.levels) {
      if (!l.stood) continue;
      ser.x.push_back(100 * l.volume_change);
      ser.y.push_back(specs[k].value(l));
    }
    p.series.push_back(ser);
    if (k == 1) {  // the threshold
      report::PlotSeries one;
      one.dashed = true;
      one.color = "#d22828";
      one.x = {100 * s.levels.front().volume_change, 100 * s.levels.back().volume_change};
      one.y = {1.0, 1.0};
      p.series.push_back(one);
      p.y_min = 0.0;
    }
  }
  return plots;
}

/// Maps: the contact pressure at the extreme levels and as designed (those donned), on one scale;
/// each written, its file added to @p outputs and the map to the report's @p section.
void write_study_maps(const std::filesystem::path& out, const DesignSetup& setup, const SockPlyResult& s,
                      nlohmann::json& outputs, report::ReportSockPly& section) {
  const auto& above = setup.solver->above_brim();
  const size_t ns = setup.solver->skin().nodes.size();
  const auto sframe = report::surface_frame(setup.model.frame);
  std::vector<report::MapLandmark> marks;
  for (const auto& l : setup.model.landmarks) marks.push_back({l.code, l.position, l.estimated});
  std::vector<int> shown{0, s.reference, static_cast<int>(s.levels.size()) - 1};
  shown.erase(std::unique(shown.begin(), shown.end()), shown.end());
  double vmax = 0;
  for (int k : shown)
    for (size_t i = 0; i < ns; ++i)
      if (!above[i]) vmax = std::max(vmax, s.levels[k].pressure_pa[i] / 1e3);
  for (int k : shown) {
    const auto& l = s.levels[k];
    if (!l.completed) continue;
    report::PressureMapData m;
    m.surface = &l.donned_skin;  // owned by the result, which outlives the report's writing
    for (size_t i = 0; i < ns; ++i)
      m.values.push_back(above[i] ? std::numeric_limits<double>::quiet_NaN() : l.pressure_pa[i] / 1e3);
    m.value_label = "kPa";
    m.value_min = 0;
    m.value_max = std::max(vmax, 1e-3);
    m.frame = sframe;
    m.landmarks = marks;
    m.title = "Contact pressure, limb " + level_name(l.volume_change);
    const std::string file = l.volume_change == 0 ? std::string("sockply_map_designed.png")
                                                  : fmt::format("sockply_map_{:+.3g}pct.png", 100 * l.volume_change);
    report::write_pressure_map(out / file, m);
    outputs.push_back(file);
    section.maps.push_back(std::move(m));
  }
}

/// A level in the summary JSON.
nlohmann::json level_json(const SockPlyLevel& l, const design::RadarTargets& targets) {
  return {{"volume_change_pct", 100 * l.volume_change},
          {"achieved_volume_change_pct", 100 * l.achieved_volume_change},
          {"skin_offset_mm", l.skin_offset_m * 1e3},
          {"completed", l.completed},
          {"stood", l.stood},
          {"message", l.message},
          {"stood_at_mm", l.stood_offset_m * 1e3},
          {"sink_mm", l.stood ? nlohmann::json(l.sink_m * 1e3) : nlohmann::json()},
          {"peak_kpa", l.peak_pressure_pa / 1e3},
          {"peak_ratio", l.peak_ratio},
          {"peak_zone", l.peak_zone},
          {"distal_mean_kpa", l.distal_mean_pa / 1e3},
          {"distal_peak_kpa", l.distal_peak_pa / 1e3},
          {"contact_nodes", l.contact_nodes},
          {"axial_force_n", l.axial_force_n},
          {"radar",
           {{"force_n", {l.radar.force_n.x(), l.radar.force_n.y(), l.radar.force_n.z()}},
            {"torque_nm", {l.radar.torque_nm.x(), l.radar.torque_nm.y(), l.radar.torque_nm.z()}},
            {"stability_n", l.radar.stability_n}}},
          {"constraints_met", l.status.all_ok()},
          {"failing", l.status.all_ok() ? "" : l.status.failing()},
          {"constraints", constraint_text(l, targets)},
          {"comfort_ok", l.status.comfort_ok},
          {"stability_ok", l.status.stability_ok},
          {"factorizations", l.factorizations},
          {"donning_seconds", l.seconds}};
}

}  // namespace

nlohmann::json write_sock_ply_outputs(const DesignSetup& setup, const DesignResult& result, const std::filesystem::path& out,
                                      report::ReportSockPly& section) {
  require(result.sock_ply.has_value(), "write_sock_ply_outputs: the design ran no sock-ply study");
  const SockPlyResult& s = *result.sock_ply;
  const auto& targets = setup.solver->targets();
  write_levels_csv(out, s);
  write_nodes_csv(out, setup, s);
  const std::vector<report::Plot> plots = study_plots(s);
  report::write_svg_grid(out / "sockply.svg", plots, 3);
  report::write_plot_grid_png(out / "sockply.png", plots, 3);
  section = {};
  nlohmann::json outputs = {"sockply.csv", "sockply_nodes.csv", "sockply.svg", "sockply.png"};
  write_study_maps(out, setup, s, outputs, section);
  section.has_study = true;
  section.summary = fmt::format(
      "The designed socket donned (friction μ = {:.2f}) and stood on with half the body weight ({:.0f} N) on the limb "
      "shrunk and grown by a uniform offset of the skin (bones fixed; stump volume {:.0f} cm³, skin {:.0f} cm²): {}.",
      s.friction, s.standing_force_n, s.stump_volume_m3 * 1e6, s.skin_area_m2 * 1e4, s.summary);
  nlohmann::json levels = nlohmann::json::array();
  for (const auto& l : s.levels) {
    report::ReportSockPlyLevel rl;
    rl.volume_change = l.volume_change;
    rl.skin_offset_m = l.skin_offset_m;
    rl.stood = l.stood;
    rl.stood_offset_m = l.stood_offset_m;
    rl.sink_m = l.sink_m;
    rl.peak_ratio = l.peak_ratio;
    rl.peak_pressure_pa = l.peak_pressure_pa;
    rl.distal_mean_pa = l.distal_mean_pa;
    rl.distal_peak_pa = l.distal_peak_pa;
    rl.contact_nodes = l.contact_nodes;
    rl.constraints = constraint_text(l, targets);
    rl.comfort_ok = l.status.comfort_ok;
    rl.stability_ok = l.status.stability_ok;
    rl.message = l.message.empty() ? "did not stand" : l.message;
    section.levels.push_back(rl);
    levels.push_back(level_json(l, targets));
  }
  section.plots = plots;
  return {{"summary", s.summary},
          {"stump_volume_cm3", s.stump_volume_m3 * 1e6},
          {"skin_area_cm2", s.skin_area_m2 * 1e4},
          {"standing_force_n", s.standing_force_n},
          {"friction", s.friction},
          {"levels", levels},
          {"seconds", s.seconds},
          {"outputs", outputs}};
}

}  // namespace socketsmith::pipeline
