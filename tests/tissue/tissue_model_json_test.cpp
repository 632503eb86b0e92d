// A tissue model's JSON in the summaries: the model's name, E and ρ, and the constants that model
// uses — and only those.
#include <gtest/gtest.h>

#include "socketsmith/tissue/tissue_model_json.h"

namespace socketsmith::tissue {
namespace {

TEST(TissueModelJson, mss_cs_lists_its_corrective_springs) {
  MassSpringOptions o;
  o.kind = TissueModelKind::MssCs;
  o.corrective = CorrectiveSpringConstants::preset("thesis");
  o.corrective.dead_zone = 0.1;
  const nlohmann::json j = tissue_model_json(o, {40e3, 1000.0});
  EXPECT_EQ(j["model"], "mss-cs");
  EXPECT_EQ(j["youngs_modulus_pa"], 40e3);
  EXPECT_EQ(j["density_kg_m3"], 1000.0);
  const nlohmann::json& c = j["corrective"];
  EXPECT_EQ(c["golec_a"], o.corrective.golec_a);
  EXPECT_EQ(c["alpha"], o.corrective.alpha);
  EXPECT_EQ(c["c"], o.corrective.c);
  EXPECT_EQ(c["beta"], o.corrective.beta);
  EXPECT_EQ(c["law"], to_string(o.corrective.law));
  EXPECT_EQ(c["spring_modulus_ratio"], o.corrective.spring_modulus_ratio);
  EXPECT_EQ(c["dead_zone"], 0.1);
  EXPECT_EQ(j.size(), 4u) << j.dump();
}

TEST(TissueModelJson, the_other_models_give_golec_a_and_their_own_poisson_ratio) {
  MassSpringOptions o;
  o.cf_poisson_ratio = 0.48;
  o.fe_poisson_ratio = 0.4;
  o.kind = TissueModelKind::MssCf;
  nlohmann::json j = tissue_model_json(o, {});
  EXPECT_EQ(j["model"], "mss-cf");
  EXPECT_EQ(j["golec_a"], o.corrective.golec_a);
  EXPECT_EQ(j["cf_poisson_ratio"], 0.48);
  EXPECT_FALSE(j.contains("fe_poisson_ratio"));
  EXPECT_FALSE(j.contains("corrective"));
  o.kind = TissueModelKind::NeoHookean;
  j = tissue_model_json(o, {});
  EXPECT_EQ(j["model"], "neo-hookean");
  EXPECT_EQ(j["fe_poisson_ratio"], 0.4);
  EXPECT_FALSE(j.contains("cf_poisson_ratio"));
  o.kind = TissueModelKind::Mss;
  j = tissue_model_json(o, {});
  EXPECT_EQ(j.size(), 4u) << j.dump();  // model, E, ρ, golec_a
}

}  // namespace
}  // namespace socketsmith::tissue
