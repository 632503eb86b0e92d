#pragma once
/// @file brim_figure.h
/// The brim templates drawn as they are placed: every template of design/brim.h (PTB, PTB-SC,
/// PTB-SCSP, KBM, TSB on the generated transtibial limb; quadrilateral and ICS on the generated
/// transfemoral limb) as h(θ) with its key points, the limb's landmarks and the stump's cut. The
/// figure of docs/socket_builder.md (docs/images/brim_templates.svg) is made by
/// `socketsmith limb brims --out docs/images/brim_templates.svg`.

#include <cstdint>
#include <filesystem>
#include <vector>

#include "socketsmith/report/plot.h"

namespace socketsmith::pipeline {

/// One panel per template, transtibial first, placed by design::make_brim on the generator's limb
/// of @p seed (volume::default_params; 0 = the nominal limb) prepared by volume::prepare_limb.
/// Panels: θ [deg] from −180 to 180, h [mm]; series "brim" (sampled every degree), "key points",
/// "cut" (the stump's top), and one marker per landmark named by its code.
std::vector<report::Plot> brim_template_plots(std::uint64_t seed = 0);

/// brim_template_plots(@p seed) as one SVG, two panels a row, written atomically to @p path.
void write_brim_template_figure(const std::filesystem::path& path, std::uint64_t seed = 0);

}  // namespace socketsmith::pipeline
