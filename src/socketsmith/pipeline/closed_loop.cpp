#include "socketsmith/pipeline/closed_loop.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <numbers>
#include <string>
#include <tuple>
#include <utility>

#include "socketsmith/core/errors.h"
#include "socketsmith/core/log.h"
#include "socketsmith/core/units.h"
#include "socketsmith/pipeline/anderson_mixing.h"
#include "socketsmith/pipeline/closed_loop_correction.h"
#include "socketsmith/pipeline/design_pipeline.h"
#include "socketsmith/report/delivery_bar.h"

namespace socketsmith::pipeline {
namespace {

using Vec3 = Eigen::Vector3d;
using Clock = std::chrono::steady_clock;
double since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

void check_options(const ClosedLoopOptions& o) {
  require(o.max_donnings >= 1 && o.max_donnings <= 20,
          "closed loop: {} donnings (expected 1-20; 1 measures the open-loop socket only)", o.max_donnings);
  require(std::isfinite(o.relaxation) && o.relaxation > 0 && o.relaxation <= 1.5,
          "closed loop: relaxation {} (expected in (0, 1.5]; 1 applies the whole correction)", o.relaxation);
  require(std::isfinite(o.mae_tolerance_pa) && o.mae_tolerance_pa > 0 && std::isfinite(o.p99_tolerance_pa) &&
              o.p99_tolerance_pa > 0,
          "closed loop: tolerances {} / {} kPa must be positive", o.mae_tolerance_pa / 1e3, o.p99_tolerance_pa / 1e3);
  require(o.refits_per_donning >= 0 && o.refits_per_donning <= 20,
          "closed loop: {} refits per donning (expected 0-20; 0 dons every corrected socket from scratch)",
          o.refits_per_donning);
  require(o.anderson_depth >= 0 && o.anderson_depth <= 10, "closed loop: Anderson depth {} (expected 0-10)",
          o.anderson_depth);
  require(o.smoothing_passes >= 0 && o.smoothing_passes <= 50, "closed loop: {} smoothing passes (expected 0-50)",
          o.smoothing_passes);
  require(std::isfinite(o.max_roughness_m) && o.max_roughness_m >= 0 && o.max_roughness_m <= 0.005,
          "closed loop: largest node-scale wall correction {} mm (expected in [0, 5] mm; 0: no cap)",
          o.max_roughness_m * 1e3);
  require(std::isfinite(o.max_offset_m) && o.max_offset_m > 0 && o.max_offset_m <= 0.02,
          "closed loop: largest wall correction {} mm (expected in (0, 20] mm)", o.max_offset_m * 1e3);
  require(!std::isnan(o.landmark_tolerance) && o.landmark_tolerance > 0,
          "closed loop: landmark tolerance {} (expected > 0; infinity: landmarks do not count)", o.landmark_tolerance);
  require(std::isfinite(o.max_brim_raise_m) && o.max_brim_raise_m >= 0 && o.max_brim_raise_m <= 0.05,
          "closed loop: largest brim raise {} mm (expected in [0, 50] mm)", o.max_brim_raise_m * 1e3);
  require(std::isfinite(o.check_newton_ratio) && o.check_newton_ratio > 0 && o.check_newton_min >= 0,
          "closed loop: a corrected socket's Newton limit {} × the open-loop donning's, at least {} (expected > 0, ≥ 0)",
          o.check_newton_ratio, o.check_newton_min);
}

constexpr double kBrimPlateau = 10.0 * std::numbers::pi / 180.0;  // ClosedLoopOptions::max_brim_raise_m
constexpr double kWorseMargin = 1.05;  // a refit is worse than its round's best above this × its score
/// A refit is checked by a donning from scratch once its tolerance_score is at most this: a refit and
/// a donning of the same socket differ by path noise (8k demo: a refit's p99 3.40 kPa, score 0.9,
/// donned at 4.14 kPa, so a third donning was needed; checked at 0.85 the next refit's 3.00 kPa donned
/// at 3.47: 2 donnings + 6 refits, 47 s instead of 3 + 6, 53 s; on the 12-limb sweep 31 donnings
/// instead of 33, and the 99th percentiles below the brim equal or lower on all 12).
constexpr double kCheckScore = 0.85;
/// ... and its landmarks within this share of ClosedLoopOptions::landmark_tolerance, the same
/// margin for the same noise: generated limb seed 6 (3k) donned a refit with the anterior distal
/// tibia 10.7 % off its design after one refit of its second round (its score 0.80), and the
/// donning delivered 11.1 %; one refit more took it to 5.8 %, and its donning to 4.7 %.
constexpr double kCheckLandmarkShare = 0.85;
/// The share of the correction applied after the second and later donnings from scratch (the
/// first correction of a round; the refits' Anderson mixing then starts from it). A donning's
/// excess over the refits before it is mostly path noise between the two, and the full step
/// overshot on it: over the transtibial, robustness and transfemoral sweeps the first refit of a
/// later round did worse than its donning 16 times in 39 (9 of 11 transfemoral, by 1.23× in the
/// median); with half the step, never (0.67–0.87× in the median), and the transfemoral limbs
/// within the whole delivery bar went 4 → 6 of 11 (2026-12-07). The open-loop donning's excess is
/// the design's error and keeps the full step.
constexpr double kRoundStepShare = 0.5;

struct RoundBest {  ///< a socket of the closed loop and its tolerance_score
  double score = std::numeric_limits<double>::infinity();
  std::vector<double> offset;
  design::SocketResult socket;
  design::BrimLine brim;
  bool donned = false;  ///< the round's donning from scratch itself (donning it again gives it again)
};

/// The shortest arc holding every angle of @p theta [rad]: (from, to) through increasing angles
/// (to < from when the arc crosses ±π).
std::pair<double, double> smallest_arc(std::vector<double> theta) {
  std::sort(theta.begin(), theta.end());
  const size_t n = theta.size();
  size_t after_gap = 0;
  double gap = theta[0] + 2 * std::numbers::pi - theta[n - 1];  // the gap across ±π
  for (size_t k = 1; k < n; ++k)
    if (theta[k] - theta[k - 1] > gap) {
      gap = theta[k] - theta[k - 1];
      after_gap = k;
    }
  return {theta[after_gap], theta[(after_gap + n - 1) % n]};
}

/// An angle of the limb frame as shown: degrees in [0, 360) from anterior towards medial.
double shown_deg(double theta) {
  const double d = theta * 180.0 / std::numbers::pi;
  return d < 0 ? d + 360.0 : d;
}

/// How far a stage is from the tolerances: max(MAE / its tolerance, p99 / its tolerance) below the
/// brim, the nodes dragged out of the socket included; ≤ 1 within. (Steering by the nodes still in
/// the socket instead stopped the loop earlier and left more nodes dragged out: on the 12 limbs of
/// docs/sweeps/closed_loop_limbs.json the 99th percentile below the brim was 2.4–13.6 kPa, 7 over
/// 4 kPa, against 2.1–9.7 kPa, 2 over, when the loop goes on while they count: its corrections of the
/// ring below the brim ease the drag, 20 nodes dragged out → 14 on seed 6.)
double tolerance_score(const ClosedLoopIteration& it, const ClosedLoopOptions& o) {
  return std::max(it.below_brim.mae / o.mae_tolerance_pa, it.below_brim.p99 / o.p99_tolerance_pa);
}

/// The landmarks' zones below the brim, with their mean threshold and designed pressure, to measure
/// each donning's landmark deviation (ClosedLoopIteration::landmark_deviation, reported).
struct LandmarkTargets {
  std::vector<LandmarkZone> zones;
  std::vector<double> threshold_pa, target_pa;
  LandmarkTargets() = default;
  LandmarkTargets(const DesignSetup& setup, const std::vector<char>& below_brim, const std::vector<double>& target)
      : zones(landmark_zones(setup, below_brim)) {
    const auto& area = setup.solver->skin().area_m2;
    for (const auto& z : zones) {
      threshold_pa.push_back(z.mean(setup.thresholds, area));
      target_pa.push_back(z.mean(target, area));
    }
  }
  /// Sets @p it's landmark deviation from @p delivered; returns each landmark's ratios.
  std::vector<report::LandmarkRatio> measure(const std::vector<double>& delivered, const std::vector<double>& area,
                                             ClosedLoopIteration& it) const {
    std::vector<report::LandmarkRatio> ratios;
    for (size_t k = 0; k < zones.size(); ++k) {
      ratios.push_back({zones[k].code, target_pa[k] / threshold_pa[k], zones[k].mean(delivered, area) / threshold_pa[k]});
      const double dev = report::landmark_deviation(ratios.back().designed, ratios.back().delivered);
      if (dev >= it.landmark_deviation) std::tie(it.landmark_deviation, it.landmark_furthest) = std::tie(dev, zones[k].code);
    }
    return ratios;
  }
};

/// One run of the closed loop: the socket worn now, its donning simulation, the counters of the
/// donnings and refits, and the result being built.
class LoopRun {
 public:
  LoopRun(DesignSetup& setup, const DesignResult& result, const ClosedLoopOptions& options)
      : setup_(setup), result_(result), options_(options), solver_(*setup.solver), skin_(solver_.skin()),
        state_(result.state), n_(skin_.nodes.size()), axis_(setup.model.frame.axis.normalized()),
        history_(options.anderson_depth), socket_(*result.socket), offset_(n_, 0.0) {
    const design::CaseFile& c = setup.case_file;
    don_ = options.donning;
    don_.start_offset_name.clear();  // `design` has no donning flags to suggest
    if (!options.keep_donning_loads) {
      don_.friction = c.patient.friction;
      don_.stand_force_n = 0.5 * c.patient.body_mass_kg * units::kGravity;
    }
    if (options.body_follows_design)
      don_.contact.linear_body = design_body_linearised(state_, c);
    don_.skin = &skin_;  // pressures per deformed area, as the design's
    sopt_ = c.socket;
    sopt_.undeformed_skin = &result.rest_skin;
    r_.linear_body = don_.contact.linear_body;
    r_.target_pa = state_.pressure_pa;
    r_.below_brim.assign(n_, 1);
    r_.ever_dragged_out.assign(n_, 0);
    for (size_t i = 0; i < n_; ++i) {
      if (solver_.above_brim()[i]) {
        r_.below_brim[i] = 0;
        r_.target_pa[i] = 0.0;
      } else {
        compared_.push_back(static_cast<int>(i));
      }
    }
    require(compared_.size() >= 3, "closed loop: only {} skin nodes lie below the brim; lower the brim",
            compared_.size());
    spacing_ = mean_spacing(skin_.area_m2, r_.below_brim);
    landmarks_ = LandmarkTargets(setup, r_.below_brim, r_.target_pa);
    std::vector<char> relieved;
    for (size_t k = 0; k < landmarks_.zones.size(); ++k)
      relieved.push_back(landmarks_.target_pa[k] < kReliefRatio * landmarks_.threshold_pa[k]);
    zone_steps_ = ZoneSteps(landmarks_.zones, relieved, skin_.area_m2, state_.skin_normals, axis_);
    for (size_t k = 0; k < landmarks_.zones.size(); ++k)
      if (zone_steps_.end(k))
        log::debug("closed loop: {} faces along the axis and carries load: no secant steps", landmarks_.zones[k].code);
    paths_ = path_nodes_below_brim(setup, r_.below_brim);
    neighbours_ = skin_.neighbours();
    socket_brim_ = setup.brim;
    lifts_.assign(n_, {});
    // The brim may rise to a node spacing below the lowest point of the skin's top edge (the
    // highest skin point of each 10° sector).
    std::vector<double> top(36, -std::numeric_limits<double>::infinity());
    for (const Vec3& v : result.deformed_skin.vertices) {
      const geometry::Cylindrical cy = setup.model.frame.to_cylindrical(v);
      const int k = std::clamp(static_cast<int>((cy.theta + std::numbers::pi) / (2 * std::numbers::pi) * 36), 0, 35);
      top[k] = std::max(top[k], cy.h);
    }
    max_brim_h_ = *std::min_element(top.begin(), top.end()) - spacing_;
  }

  ClosedLoopResult run() {
    contact::DonningResult d = don_from_scratch();
    bool refitted = false;
    for (;;) {
      if (!d.completed || !d.stood) {
        if (!recover(d, refitted)) break;
        continue;
      }
      const std::vector<double> delivered = record(d, refitted);
      const ClosedLoopIteration& it = r_.iterations.back();
      const double score = tolerance_score(it, options_);
      const bool within = score <= 1.0 && it.landmark_deviation <= options_.landmark_tolerance &&
                          (!options_.paths_within_bar || it.path_score <= 1.0);
      if (!refitted && start_round(score, within, delivered, d)) break;
      // A refit within the tolerances by a margin (kCheckScore, kCheckLandmarkShare), or the last
      // of a round, is checked by a donning from scratch; so is the round's best when a refit does
      // worse (1.8k: refits drift from the fourth on); when the round's first refit does worse than
      // its donning, nothing is left to gain: the loop stops.
      // Worse means kWorseMargin above the round's best: a refit and a donning from scratch differ
      // by path noise (OpenLimb 3k: a round's first refit at MAE 0.69 / p99 4.38 kPa after its
      // donning's 0.67 / 5.17 stopped the loop there; two more refits and a donning reached 0.39 / 3.45).
      const bool worse = refitted && score >= kWorseMargin * round_.score;
      if (worse && refits_ == 1 && full_donnings_ == 1 && !halved_) {
        // The first correction of the open-loop socket overshot: try half of it once (generated
        // limb, seed 8 at 80 kg and E 100 kPa with a 5 mm brim flare: refit 1 at MAE 4.37 / p99
        // 19.5 kPa after the donning's 4.11 / 14.4 stopped the loop with the open-loop socket).
        halved_ = true;
        for (auto& v : offset_) v *= 0.5;
        history_.clear();
        log::info("closed loop: the first correction did worse than the open-loop socket; trying half of it");
        if (!rebuild_socket()) break;
        d = sim_->refit(socket_.solid);
        continue;
      }
      // When the round's donning missed the delivery bar only by a landmark or a path, what it
      // missed is what refits see least: donned from scratch, the socket of a refit presses a
      // landmark's zone otherwise (generated limbs, seeds 3 and 4: the anterior distal tibia
      // 1.3–1.5 kPa under the refit of the same socket, 0.014–0.021 of its threshold under its
      // design, where 0.1 mm of wall moves it 2–4 kPa). So a refit that does worse by the score is
      // donned from scratch all the same, while donnings are left.
      const bool don_to_see = round_missed_only_landmark_or_path_;
      if (worse && refits_ == 1 && !don_to_see) break;
      if (refitted && score < round_.score) round_ = {score, offset_, socket_, socket_brim_, false};
      const bool check = score <= kCheckScore &&
                         it.landmark_deviation <= kCheckLandmarkShare * options_.landmark_tolerance;
      if (refitted && (check || worse || refits_ >= options_.refits_per_donning)) {
        if (full_donnings_ >= options_.max_donnings) break;
        if (score > round_.score) {
          // The round's best: a refit's socket is donned instead of this one; the round's donning
          // itself would give what it gave (seed 3 donned the same socket twice before).
          if (!round_.donned)
            std::tie(offset_, socket_, socket_brim_) = std::tie(round_.offset, round_.socket, round_.brim);
          else if (!don_to_see)
            break;
        }
        d = don_from_scratch();
        refitted = false;
        continue;
      }
      if (!refitted && full_donnings_ >= options_.max_donnings) break;
      if (!correct_wall(delivered, refitted)) break;
      if (options_.refits_per_donning > 0) {
        ++refits_;
        d = sim_->refit(socket_.solid);
        refitted = true;
      } else {
        d = don_from_scratch();
        refitted = false;
      }
    }
    return finish();
  }

 private:
  /// A donning from scratch of score @p score (tolerance_score), @p within every tolerance or not,
  /// starts a round: kept if it is the best so far. True when it converged (the loop stops).
  bool start_round(double score, bool within, const std::vector<double>& delivered, const contact::DonningResult& d) {
    const ClosedLoopIteration& it = r_.iterations.back();
    round_ = {score, offset_, socket_, socket_brim_, true};
    round_missed_only_landmark_or_path_ = it.bar_below_brim_met && !it.bar_met;
    keep_if_best(score, within, it.bar_met, delivered, d);
    if (!within) return false;
    r_.converged = true;
    r_.message = fmt::format("converged after {} donnings and {} refits: below the brim MAE {:.2f} kPa, 99th "
                             "percentile {:.2f} kPa{}{}",
                             full_donnings_, r_.iterations.size() - full_donnings_, it.below_brim.mae / 1e3,
                             it.below_brim.p99 / 1e3, landmark_note(it), dragged_out_note(it));
    return true;
  }

  /// The socket as it is now donned with @p o (a new simulation: the refits go on from it).
  contact::DonningResult don_with(const contact::DonningOptions& o) {
    sim_ = std::make_unique<contact::DonningSimulation>(solver_.model(), skin_.nodes, skin_.area_m2, socket_.solid,
                                                        setup_.model.frame, o);
    return sim_->run();
  }

  /// A socket whose donning @p failed (a stall at a bulge, a standing push without equilibrium)
  /// donned again on a path of half the steps: where a path stalls moves with the path (AAOP
  /// example at 8k: a corrected socket stalled standing; on the finer path it stood).
  contact::DonningResult don_again_on_a_finer_path(const contact::DonningResult& failed) {
    log::info("closed loop: the socket's donning failed ({}); donning it again on a path of half the steps",
              failed.message.empty() ? "the standing load was not reached" : failed.message);
    ++r_.retried_donnings;
    contact::DonningOptions finer = don_;
    finer.step_m *= 0.5;
    finer.min_step_m = std::min(finer.min_step_m, finer.step_m);
    return don_with(finer);
  }

  /// A full donning of the socket as it is now (the path from below, then standing).
  contact::DonningResult don_from_scratch() {
    const double lo = static_cast<double>(full_donnings_) / options_.max_donnings;
    const double hi = static_cast<double>(full_donnings_ + 1) / options_.max_donnings;
    don_.progress = [this, lo, hi, first = full_donnings_ == 0](double f, std::string_view) {
      return report_progress(options_.progress, lo + (hi - lo) * f,
                             first ? "closed loop: donning the open-loop socket" : "closed loop: donning the corrected socket");
    };
    ++full_donnings_;
    refits_ = 0;
    contact::DonningResult d = don_with(don_);
    if (!(d.completed && d.stood)) d = don_again_on_a_finer_path(d);
    if (full_donnings_ == 1 && d.completed) {
      // ClosedLoopOptions::check_newton_ratio
      const auto cap = static_cast<long>(
          std::max({1.0, static_cast<double>(options_.check_newton_min),
                             options_.check_newton_ratio * static_cast<double>(d.newton_spent)}));
      if (don_.max_newton_iterations == 0 || cap < don_.max_newton_iterations)
        don_.max_newton_iterations = static_cast<int>(cap);
      log::debug("closed loop: the open-loop donning spent {} Newton iterations; a corrected socket's may spend {}",
                 d.newton_spent, don_.max_newton_iterations);
    }
    return d;
  }

  /// A donning or refit that did not stand: a failed refit is donned from scratch (true: go on);
  /// otherwise the loop stops with the reason (false). The open-loop socket's failure throws.
  bool recover(contact::DonningResult& d, bool& refitted) {
    const std::string why = d.message.empty() ? "the standing load was not reached" : d.message;
    require<SolverError>(!r_.iterations.empty(),
                         "closed loop: the open-loop socket could not be donned and stood on: {} (design without "
                         "\"closed_loop\" to keep the open-loop socket)",
                         why);
    if (!refitted) {
      r_.message = fmt::format("stopped after {} donnings: the corrected socket could not be donned and stood on ({})",
                               full_donnings_, why);
      return false;
    }
    // The refit lost its way: don the same socket from scratch instead.
    log::warn("closed loop: the refit of the corrected socket did not converge ({}); donning it from scratch", why);
    if (full_donnings_ >= options_.max_donnings) {
      r_.message = fmt::format("stopped: the corrected socket's refit failed ({}) and no donning is left", why);
      return false;
    }
    d = don_from_scratch();
    refitted = false;
    return true;
  }

  /// @p delivered against the design below the brim, at the landmarks and on the paths, and
  /// against the delivery bar: @p it's figures.
  void judge(const std::vector<double>& delivered, ClosedLoopIteration& it) const {
    it.below_brim = report::compare_fields(delivered, r_.target_pa, compared_);
    const std::vector<report::LandmarkRatio> ratios = landmarks_.measure(delivered, skin_.area_m2, it);
    const report::DeliveryBar bar;
    std::vector<report::PathDelivery> path_stats;
    for (const auto& p : paths_) {
      const auto e = report::compare_fields(delivered, r_.target_pa, p.nodes);
      path_stats.push_back({p.name, e});
      const double score = std::max(e.mae / bar.mae_pa, e.p99 / bar.p99_pa);
      if (score >= it.path_score)
        std::tie(it.path_score, it.path_furthest, it.path_mae_pa, it.path_p99_pa) = std::tie(score, p.name, e.mae, e.p99);
    }
    const report::DeliveryVerdict verdict = report::judge_delivery(it.below_brim, ratios, path_stats, bar);
    it.bar_met = verdict.met();
    it.bar_below_brim_met = verdict.mae_met && verdict.p99_met && verdict.r_met;
  }

  /// The delivered pressures of donning or refit @p d, measured against the design and logged as
  /// the next iteration of the result.
  std::vector<double> record(const contact::DonningResult& d, bool refitted) {
    ClosedLoopIteration it;
    it.refit = refitted;
    for (size_t i = 0; i < n_; ++i) {
      it.max_offset_m = std::max(it.max_offset_m, std::abs(offset_[i]));
      if (r_.below_brim[i]) it.mean_offset_m += offset_[i] / static_cast<double>(compared_.size());
    }
    const WallRoughness rough = wall_roughness(neighbours_, skin_.area_m2, r_.below_brim, offset_);
    it.wall_roughness_rms_m = rough.rms_m;
    it.wall_roughness_p99_m = rough.p99_m;
    it.wall_roughness_share = rough.share();
    std::vector<double> delivered(n_);
    for (size_t i = 0; i < n_; ++i) delivered[i] = d.contacts[i].pressure_pa;
    judge(delivered, it);
    donned_ = donned_in_socket(skin_, d, axis_);
    in_socket_.clear();
    dragged_out_.assign(n_, 0);
    std::vector<double> angles;
    for (int i : compared_) {
      const geometry::Cylindrical cy = setup_.model.frame.to_cylindrical(donned_[i]);
      const double above = cy.h - socket_brim_.height(cy.theta);  // as design::above_brim
      if (above <= 0) {
        in_socket_.push_back(i);
        continue;
      }
      // ClosedLoopOptions::max_brim_raise_m: the next socket's brim clears this node by half a spacing.
      const double lift = std::min(cy.h - setup_.brim.height(cy.theta) + 0.5 * spacing_, options_.max_brim_raise_m);
      if (lift > lifts_[i].lift_m) lifts_[i] = {cy.theta, lift};
      dragged_out_[i] = r_.ever_dragged_out[i] = 1;
      ++it.dragged_out;
      it.dragged_out_max_target_pa = std::max(it.dragged_out_max_target_pa, r_.target_pa[i]);
      it.dragged_out_height_m = std::max(it.dragged_out_height_m, above);
      angles.push_back(cy.theta);
    }
    if (!angles.empty()) {
      const auto [from, to] = smallest_arc(angles);
      it.dragged_out_from_deg = shown_deg(from);
      it.dragged_out_to_deg = shown_deg(to);
    }
    if (in_socket_.size() >= 3) it.in_socket = report::compare_fields(delivered, r_.target_pa, in_socket_);
    for (int k = 0; k < 720; ++k) {  // how far socket_'s brim lies above the design's
      const double theta = -std::numbers::pi + k * std::numbers::pi / 360;
      it.brim_raise_m = std::max(it.brim_raise_m, socket_brim_.height(theta) - setup_.brim.height(theta));
    }
    it.stood_offset_m = d.final_offset_m;
    it.axial_friction_n = d.series.empty() ? 0.0 : d.series.back().axial_friction_n;
    it.factorizations = d.series.empty() ? 0 : static_cast<int>(d.series.back().factorizations);
    it.donning_seconds = d.seconds;
    it.socket_seconds = socket_seconds_;
    log::info("closed loop: {} {} — below the brim MAE {:.2f} kPa, 99th percentile {:.2f} kPa, R {:.3f}, mean {:.2f} vs "
              "{:.2f} kPa designed{}; friction carries {:.0f} N ({:.0f} N designed); wall moved up to {:.2f} mm; {:.1f} s",
              refitted ? "refit" : "donning", refitted ? refits_ : full_donnings_, it.below_brim.mae / 1e3,
              it.below_brim.p99 / 1e3, it.below_brim.r, it.below_brim.mean_a / 1e3, it.below_brim.mean_b / 1e3,
              landmark_note(it) + path_note(it),
              it.axial_friction_n, state_.radar.stability_n, it.max_offset_m * 1e3, d.seconds);
    if (it.dragged_out > 0) log::info("closed loop: {} —{}", refitted ? "refit" : "donning", dragged_out_note(it));
    if (it.brim_raise_m > 0)
      log::info("closed loop: the socket's brim rose up to {:.1f} mm above the design's", it.brim_raise_m * 1e3);
    // Friction: the design counts on sliding friction μ p at every node (its axial share μ p |n × a|);
    // donned and stood, the socket mobilises a share of what its delivered pressures make available
    // (nodes stuck by the donning's friction history carry less).
    const double mu = setup_.case_file.patient.friction;
    double available = 0;
    for (int i : compared_)
      available += design::axial_friction_n(delivered[i], state_.skin_areas[i], state_.skin_normals[i], axis_, mu);
    it.friction_utilisation = available > 0 ? it.axial_friction_n / available : 1.0;
    r_.delivered_by_iteration.push_back(delivered);
    r_.offset_by_iteration.push_back(offset_);
    if (r_.iterations.empty()) r_.open_loop_pa = delivered;
    r_.iterations.push_back(it);
    return delivered;
  }

  /// The socket kept, among those donned from scratch: one @p within every tolerance (landmarks
  /// and paths included) before one that meets the delivery bar (ClosedLoopIteration::bar_met),
  /// before one that meets neither, then the smallest max(MAE / tol, p99 / tol) — of those that
  /// meet neither, the one closest to the bar (bar_score).
  void keep_if_best(double score, bool within, bool bar_met, const std::vector<double>& delivered,
                    const contact::DonningResult& d) {
    if (kept_rank(within, bar_met) == 0) score = bar_score(r_.iterations.back());
    if (!replaces_kept(within, bar_met, score, best_rank_, best_score_)) return;
    best_score_ = score;
    best_rank_ = kept_rank(within, bar_met);
    r_.best = static_cast<int>(r_.iterations.size()) - 1;
    r_.closed_loop_pa = delivered;
    r_.wall_offset_m = offset_;
    r_.dragged_out = dragged_out_;
    r_.socket = socket_;
    r_.socket_brim = socket_brim_;
    r_.donning = d;
  }

  /// The next wall: the correction of the last donning's @p delivered pressures (each landmark's
  /// zone stepped by its own secant, ZoneSteps; Anderson-mixed over the round's refits), the
  /// designed skin moved by δ along its normals, the socket built on it. False when the socket
  /// could not be built (the loop stops with the reason).
  bool correct_wall(const std::vector<double>& delivered, bool refitted) {
    std::vector<double> on_wall = wall_corrections(solver_, state_, in_socket_, delivered, r_.target_pa, donned_,
                                                   offset_, spacing_, options_);
    std::vector<double> excess(n_);
    for (size_t i = 0; i < n_; ++i) excess[i] = delivered[i] - r_.target_pa[i];
    zone_steps_.apply(excess, offset_, refitted, on_wall);
    for (size_t k = 0; k < landmarks_.zones.size(); ++k)
      if (zone_steps_.slope(k) < 0)
        log::debug("closed loop: {}'s wall stepped by its own slope, {:.3g} kPa/mm", landmarks_.zones[k].code,
                   -zone_steps_.slope(k) / 1e6);
    if (!refitted) history_.clear();  // a donning from scratch: the refits' map starts again
    if (!refitted && full_donnings_ >= 2) {  // a later round's first correction: half of it
      for (size_t i = 0; i < n_; ++i) offset_[i] += kRoundStepShare * on_wall[i];
    } else {
      offset_ = history_.next(offset_, on_wall);
    }
    for (auto& v : offset_) v = std::clamp(v, -options_.max_offset_m, options_.max_offset_m);
    if (options_.max_roughness_m > 0)
      cap_node_scale_part(neighbours_, skin_.area_m2, r_.below_brim, options_.max_roughness_m, offset_);
    return rebuild_socket();
  }

  /// The socket on the designed skin moved by offset_ along its normals (its brim raised where the
  /// skin was dragged out, ClosedLoopOptions::max_brim_raise_m). False when it could not be built
  /// (the loop stops with the reason).
  bool rebuild_socket() {
    const auto ts = Clock::now();
    geometry::TriMesh inner = result_.deformed_skin;
    for (size_t i = 0; i < n_; ++i) inner.vertices[i] += offset_[i] * state_.skin_normals[i];
    try {
      if (options_.max_brim_raise_m > 0)
        socket_brim_ = design::raise_brim(setup_.brim, lifts_, kBrimPlateau, max_brim_h_);
      socket_ = design::build_socket(inner, setup_.model.frame, socket_brim_, sopt_);
    } catch (const Error& e) {
      r_.message = fmt::format("stopped after {} donnings: the corrected socket could not be built ({})",
                               full_donnings_, e.what());
      return false;
    }
    socket_seconds_ = since(ts);
    return true;
  }

  ClosedLoopResult finish() {
    for (int k = 0; k <= r_.best; ++k) r_.kept_donning += r_.iterations[k].refit ? 0 : 1;
    if (r_.message.empty()) {
      const ClosedLoopIteration& kept = r_.iterations[r_.best];
      const auto& b = kept.below_brim;  // all of them, the dragged-out ones included
      r_.message = fmt::format("{} donnings without meeting the tolerances (MAE {:.2f}, p99 {:.2f} kPa, landmarks "
                               "within {:.0f} %{}); "
                               "kept donning {}: MAE {:.2f} kPa, 99th percentile {:.2f} kPa{}{}{}",
                               full_donnings_, options_.mae_tolerance_pa / 1e3, options_.p99_tolerance_pa / 1e3,
                               100 * options_.landmark_tolerance,
                               options_.paths_within_bar ? ", each thesis path within the delivery bar" : "",
                               r_.kept_donning, b.mae / 1e3, b.p99 / 1e3,
                               landmark_note(kept), path_note(kept), dragged_out_note(kept));
    }
    return std::move(r_);
  }

  DesignSetup& setup_;
  const DesignResult& result_;
  const ClosedLoopOptions& options_;
  design::DesignSolver& solver_;
  const volume::SkinSurface& skin_;
  const design::DesignState& state_;
  const size_t n_;
  const Vec3 axis_;
  contact::DonningOptions don_;
  design::SocketOptions sopt_;
  std::vector<int> compared_;  // skin nodes below the brim
  design::BrimLine socket_brim_;             // the brim of socket_ (ClosedLoopOptions::max_brim_raise_m)
  std::vector<design::BrimLift> lifts_;      // per skin node: how far the brim must rise for it, where
  double max_brim_h_ = 0;                    // the brim rises no higher than this [m]
  LandmarkTargets landmarks_;  // the landmarks' zones below the brim
  ZoneSteps zone_steps_;       // their walls' secant steps
  std::vector<PathNodes> paths_;  // each thesis path's nodes below the brim
  std::vector<std::vector<int>> neighbours_;  // each skin node's, on the skin's quads
  std::vector<Vec3> donned_;       // the last donning's skin, in the socket's frame
  std::vector<int> in_socket_;     // compared nodes it left below the brim
  std::vector<char> dragged_out_;  // per skin node: compared, and dragged above the brim
  double spacing_ = 0;         // their mean spacing [m]
  AndersonMixing history_;
  design::SocketResult socket_;  // the socket worn now
  std::vector<double> offset_;   // its δ per skin node [m]
  double socket_seconds_ = 0;
  std::unique_ptr<contact::DonningSimulation> sim_;
  int full_donnings_ = 0, refits_ = 0;
  double best_score_ = std::numeric_limits<double>::infinity();
  int best_rank_ = -1;  // the kept socket's: 2 within the tolerances (landmarks', paths'), 1 the delivery bar, 0
  bool halved_ = false;       // the first correction was halved once (run)
  RoundBest round_;  // the best socket since the last donning from scratch, that donning's included
  bool round_missed_only_landmark_or_path_ = false;  // that donning's delivery bar
  ClosedLoopResult r_;
};

}  // namespace

int kept_rank(bool within, bool bar_met) { return within ? 2 : bar_met ? 1 : 0; }

double bar_score(const ClosedLoopIteration& it) {
  const report::DeliveryBar bar;
  return std::max({it.below_brim.mae / bar.mae_pa, it.below_brim.p99 / bar.p99_pa,
                   it.landmark_deviation / bar.landmark_tolerance, it.path_score});
}

bool replaces_kept(bool within, bool bar_met, double score, int kept_rank_now, double kept_score) {
  const int rank = kept_rank(within, bar_met);
  return rank == kept_rank_now ? score < kept_score : rank > kept_rank_now;
}

ClosedLoopResult close_design_loop(DesignSetup& setup, const DesignResult& result, const ClosedLoopOptions& options) {
  check_options(options);
  require(result.socket.has_value() && result.constraints_met,
          "closed loop: the design does not meet its constraints, so it has no socket to don; fix the design first");
  const auto t0 = Clock::now();
  ClosedLoopResult r = LoopRun(setup, result, options).run();
  r.seconds = since(t0);
  report_progress(options.progress, 1.0, "closed loop: done");
  return r;
}

}  // namespace socketsmith::pipeline
