#pragma once
/// @file limb_views.h
/// Pictures of a limb model: translucent skin over opaque bones with the landmarks, seen from
/// the front, the lateral side, the back and the medial side of the limb frame.

#include <string>
#include <vector>

#include "socketsmith/geometry/limb_frame.h"
#include "socketsmith/report/raster.h"
#include "socketsmith/volume/bone_template.h"
#include "socketsmith/volume/landmarks.h"

namespace socketsmith::report {

/// Four views (anterior, lateral, posterior, medial) of @p skin with @p bones and labelled
/// @p landmarks (a landmark is drawn in the views where it is not hidden by the skin itself).
/// @param bones_estimated adds "(bones estimated)" to the title.
Image render_limb_views(const geometry::TriMesh& skin, const std::vector<volume::NamedMesh>& bones,
                        const std::vector<volume::Landmark>& landmarks, const geometry::LimbFrame& frame,
                        const std::string& title, bool bones_estimated, int view_px = 360);

}  // namespace socketsmith::report
