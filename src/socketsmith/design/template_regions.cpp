#include "socketsmith/design/template_regions.h"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "socketsmith/core/errors.h"
#include "socketsmith/design/design_solver.h"

namespace socketsmith::design {

TemplateRegions template_regions(BrimTemplate kind) {
  switch (kind) {
    case BrimTemplate::Ptb:
    case BrimTemplate::PtbSc:
    case BrimTemplate::PtbScsp:
    case BrimTemplate::Kbm: return {{"PT", "MF", "LF", "POP"}, {"FH", "TC", "AD", "DT"}, false};
    case BrimTemplate::Tsb: return {{}, {}, true};
    default: return {};
  }
}

namespace {

/// The nodes of a region: below the brim, within the radius of any of @p codes' landmarks.
std::vector<char> region_nodes(const std::vector<std::string>& codes, const std::vector<volume::Landmark>& landmarks,
                               const std::vector<Eigen::Vector3d>& rest, const std::vector<char>& above,
                               std::vector<std::string>& found) {
  std::vector<char> in(rest.size(), 0);
  for (const auto& code : codes)
    for (const auto& l : landmarks) {
      if (l.code != code) continue;
      found.push_back(code);
      for (size_t i = 0; i < rest.size(); ++i)
        if (!above[i] && (rest[i] - l.position).norm() <= l.radius_m) in[i] = 1;
    }
  return in;
}

}  // namespace

TemplateMasks template_masks(BrimTemplate kind, const std::vector<volume::Landmark>& landmarks,
                             const std::vector<Eigen::Vector3d>& rest, const std::vector<char>& above,
                             const geometry::LimbFrame& frame, double stump_length_m) {
  require(rest.size() == above.size(), "template_masks: {} positions and {} brim flags (expected one each per skin node)",
          rest.size(), above.size());
  TemplateMasks m;
  const TemplateRegions t = template_regions(kind);
  m.tolerant = region_nodes(t.tolerant, landmarks, rest, above, m.tolerant_codes);
  m.sensitive = region_nodes(t.sensitive, landmarks, rest, above, m.sensitive_codes);
  m.distal_fifth.assign(rest.size(), 0);
  m.below_brim.assign(rest.size(), 0);
  for (size_t i = 0; i < rest.size(); ++i) {
    m.below_brim[i] = above[i] ? 0 : 1;
    m.distal_fifth[i] = frame.to_cylindrical(rest[i]).h <= 0.2 * stump_length_m ? 1 : 0;
  }
  return m;
}

TemplateCheck check_template(BrimTemplate kind, const std::vector<volume::Landmark>& landmarks, const SkinLoads& s,
                             const geometry::LimbFrame& frame, double stump_length_m, double friction) {
  require(s.rest_positions && s.normals && s.areas_m2 && s.pressures_pa && s.above_brim,
          "check_template: the skin data are incomplete");
  const size_t n = s.rest_positions->size();
  require(s.normals->size() == n && s.areas_m2->size() == n && s.pressures_pa->size() == n && s.above_brim->size() == n,
          "check_template: {} positions, {} normals, {} areas, {} pressures, {} brim flags (expected one each per skin "
          "node)",
          n, s.normals->size(), s.areas_m2->size(), s.pressures_pa->size(), s.above_brim->size());
  require(std::isfinite(stump_length_m) && stump_length_m > 0, "check_template: stump length {} m must be positive",
          stump_length_m);
  const Eigen::Vector3d axis = frame.axis.normalized();
  std::vector<double> axial(n, 0.0);
  TemplateCheck c;
  c.template_name = to_string(kind);
  for (size_t i = 0; i < n; ++i) {
    axial[i] = axial_load_n((*s.pressures_pa)[i], (*s.areas_m2)[i], (*s.normals)[i], axis, friction);
    c.total_axial_n += axial[i];
  }
  const auto measure = [&](const std::string& key, const std::vector<char>& in, std::vector<std::string> codes) {
    ZoneLoad r;
    r.key = key;
    r.codes = std::move(codes);
    double area = 0;
    for (size_t i = 0; i < n; ++i) {
      if (!in[i]) continue;
      const double p = (*s.pressures_pa)[i], a = (*s.areas_m2)[i];
      ++r.nodes;
      area += a;
      r.mean_pa += p * a;
      r.peak_pa = std::max(r.peak_pa, p);
      r.axial_force_n += axial[i];
    }
    if (area > 0) r.mean_pa /= area;
    if (c.total_axial_n > 0) r.axial_share = r.axial_force_n / c.total_axial_n;
    return r;
  };
  const TemplateRegions t = template_regions(kind);
  const TemplateMasks m = template_masks(kind, landmarks, *s.rest_positions, *s.above_brim, frame, stump_length_m);
  const auto& below = m.below_brim;
  c.tolerant = measure("tolerant", m.tolerant, m.tolerant_codes);
  c.sensitive = measure("sensitive", m.sensitive, m.sensitive_codes);
  c.distal_fifth = measure("distal_fifth", m.distal_fifth, {});
  c.below_brim = measure("below_brim", below, {});
  {
    double area = 0, var = 0;
    for (size_t i = 0; i < n; ++i)
      if (below[i]) {
        const double d = (*s.pressures_pa)[i] - c.below_brim.mean_pa;
        var += d * d * (*s.areas_m2)[i];
        area += (*s.areas_m2)[i];
      }
    c.cv_below_brim = area > 0 && c.below_brim.mean_pa > 0 ? std::sqrt(var / area) / c.below_brim.mean_pa : 0.0;
  }
  if (c.sensitive.mean_pa > 0) c.tolerant_to_sensitive = c.tolerant.mean_pa / c.sensitive.mean_pa;
  const std::string name = c.template_name;
  if (!t.tolerant.empty() && c.tolerant.nodes > 0 && c.sensitive.nodes > 0) {
    c.applies = true;
    const bool bears = c.tolerant.mean_pa >= kMinTolerantToSensitive * c.sensitive.mean_pa;
    const bool distal_ok = c.distal_fifth.axial_share <= kMaxDistalFifthShare;
    c.met = bears && distal_ok;
    c.summary = fmt::format("{}: tolerant regions {:.1f} kPa, {:.2f} × the sensitive ones ({:.1f} kPa; at least 1.5 ×: "
                            "{}), distal fifth {:.0f} % of the axial load (at most 10 %: {})",
                            name, c.tolerant.mean_pa / 1e3, c.tolerant_to_sensitive, c.sensitive.mean_pa / 1e3,
                            bears ? "yes" : "no", 100 * c.distal_fifth.axial_share, distal_ok ? "yes" : "no");
  } else if (t.uniform) {
    c.applies = true;
    c.met = c.cv_below_brim <= kMaxCvBelowBrim;
    c.summary = fmt::format("{}: coefficient of variation below the brim {:.2f} (at most 0.35: {}), distal fifth {:.0f} % "
                            "of the axial load",
                            name, c.cv_below_brim, c.met ? "yes" : "no", 100 * c.distal_fifth.axial_share);
  } else {
    c.summary = fmt::format("{}: no region table for this template; distal fifth {:.0f} % of the axial load, coefficient "
                            "of variation below the brim {:.2f}",
                            name, 100 * c.distal_fifth.axial_share, c.cv_below_brim);
  }
  return c;
}

}  // namespace socketsmith::design
