#include "socketsmith/tissue/tissue_model_json.h"

namespace socketsmith::tissue {

nlohmann::json tissue_model_json(const MassSpringOptions& o, const TissueMaterial& m) {
  nlohmann::json j;
  j["model"] = to_string(o.kind);
  j["youngs_modulus_pa"] = m.youngs_modulus_pa;
  j["density_kg_m3"] = m.density_kg_m3;
  if (o.kind == TissueModelKind::MssCs)
    j["corrective"] = {{"golec_a", o.corrective.golec_a}, {"alpha", o.corrective.alpha}, {"c", o.corrective.c},
                       {"beta", o.corrective.beta}, {"law", to_string(o.corrective.law)},
                       {"spring_modulus_ratio", o.corrective.spring_modulus_ratio},
                       {"dead_zone", o.corrective.dead_zone}};
  else
    j["golec_a"] = o.corrective.golec_a;
  if (o.kind == TissueModelKind::MssCf) j["cf_poisson_ratio"] = o.cf_poisson_ratio;
  if (is_continuum(o.kind)) {
    j["fe_poisson_ratio"] = o.fe_poisson_ratio;
    j["element"] = to_string(o.hex_formulation);
  }
  return j;
}

}  // namespace socketsmith::tissue
