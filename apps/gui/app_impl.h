#pragma once
/// @file app_impl.h
/// What App's files share (private to apps/gui): the panels' widths and the colour map of a field.
/// App's methods are defined by what they draw: the core (the session, the GPU scene, the frame) in
/// app.cpp, each panel in its panel_*.cpp, the view's overlay in viewport_overlay.cpp, its mouse in
/// view_input.cpp, the menu and the dialogs in dialogs.cpp.

#include <numbers>

#include "app.h"
#include "socketsmith/report/raster.h"

namespace socketsmith::gui {

constexpr double kDeg = std::numbers::pi / 180.0;
constexpr float kLeftPanel = 390, kRightPanel = 440;  ///< the Design and Feedback panels' widths [px]

/// The fields shown on a diverging map, symmetric about 0: the deviation of a compared shape, the
/// rectification and delivered minus designed.
inline bool is_signed(Field field) {
  return field == Field::Deviation || field == Field::Rectification || field == Field::DeliveryError;
}

/// The colour map of a field: viridis for the thresholds, diverging (blue inside, red outside) for
/// the signed fields (as the report's), the clinicians' pressure map for the rest.
inline report::Colormap field_colormap(Field field) {
  return field == Field::Threshold ? report::Colormap::Viridis
         : is_signed(field)        ? report::Colormap::Diverging
                                   : report::Colormap::Pressure;
}

}  // namespace socketsmith::gui
