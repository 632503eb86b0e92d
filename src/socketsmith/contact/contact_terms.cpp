#include "socketsmith/contact/contact_terms.h"

namespace socketsmith::contact {

PenaltyTerm penalty_term(const Gap& gap, double kA, double lambda_n) {
  PenaltyTerm p;
  const double push = lambda_n - kA * gap.gap_m;  // λ + k A (−gap)
  if (!gap.valid || !(push > 0)) return p;
  p.active = true;
  p.normal_force_n = push * gap.gradient_norm;
  NodeTerm& t = p.term;
  t.energy = 0.5 * push * push / kA;
  t.force = p.normal_force_n * gap.normal;
  // Inside a face: stiffness along the normal only; on an edge or a vertex the force points to a
  // fixed point of the wall (f = kA (c − x)), stiff in every direction.
  t.stiffness = kA * gap.stiffness_shape;
  return p;
}

FrictionTerm friction_term(const FrictionInput& in) {
  FrictionTerm out;
  const double limit = in.limit_n, kT = in.stick_stiffness;
  if (!(limit > 0)) return out;
  const Vec3& nl = in.lag_normal;
  const Eigen::Matrix3d Pt = Eigen::Matrix3d::Identity() - nl * nl.transpose();
  const Vec3 slip = Pt * in.displacement_m;
  const Vec3 trial = Pt * in.history_n + kT * slip;
  const double mag = trial.norm();
  if (mag > limit) {
    out.sliding = true;
    out.spring_force_n = trial * (limit / mag);
    const Vec3 that = trial / mag;
    out.term.stiffness = (limit / mag) * kT * (Pt - that * that.transpose());
    out.term.energy = limit * mag / kT - 0.5 * limit * limit / kT;
  } else {
    out.spring_force_n = trial;
    out.term.stiffness = kT * Pt;
    out.term.energy = 0.5 * mag * mag / kT;
  }
  out.term.force = -out.spring_force_n;
  return out;
}

}  // namespace socketsmith::contact
