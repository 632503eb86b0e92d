#pragma once
/// @file tissue_model_json.h
/// A tissue model's options and material as the summaries write them (`simulate cube`'s
/// summary.json, `mesh --load-kpa`'s mesh.json): the model's name, E and ρ, and the constants that
/// model uses — MSS-CS its corrective springs, the others Golec's A, MSS-CF its Poisson ratio, the
/// continuum models theirs.

#include <nlohmann/json.hpp>

#include "socketsmith/tissue/mass_spring_model.h"

namespace socketsmith::tissue {

/// {"model", "youngs_modulus_pa", "density_kg_m3", and "corrective" {golec_a, alpha, c, beta, law,
/// spring_modulus_ratio, dead_zone} (MSS-CS) or "golec_a" (the others), "cf_poisson_ratio"
/// (MSS-CF), "fe_poisson_ratio" (fe, neo-hookean)}, in SI units.
nlohmann::json tissue_model_json(const MassSpringOptions& options, const TissueMaterial& material);

}  // namespace socketsmith::tissue
