#pragma once
/// @file limb_model.h
/// From a limb file (skin, maybe open, maybe with bone shells) to a prepared limb: closed skin
/// trimmed at a plane normal to the axis, named closed bones inside it (or estimated ones), the
/// limb frame, and the landmarks — everything the hexahedral mesher and the design need.

#include <optional>
#include <string>
#include <vector>

#include "socketsmith/geometry/limb_frame.h"
#include "socketsmith/geometry/mesh_io.h"
#include "socketsmith/geometry/mesh_repair.h"
#include "socketsmith/geometry/tri_mesh.h"
#include "socketsmith/volume/bone_template.h"
#include "socketsmith/volume/hex_mesh.h"
#include "socketsmith/volume/hex_mesher.h"
#include "socketsmith/volume/landmarks.h"
#include "socketsmith/volume/transfemoral_anatomy.h"

namespace socketsmith::volume {

/// How to read the limb. Every field may be left at its default.
struct LimbInputOptions {
  geometry::LimbType type = geometry::LimbType::Transtibial;
  std::optional<Vec3> axis;                   ///< world direction of the long axis (overrides the femur and the skin)
  std::optional<Vec3> anterior;               ///< world direction of the front (overrides estimates)
  std::optional<geometry::Side> side;         ///< overrides the side derived from bones
  std::optional<double> cut_height_m;         ///< proximal cut above the distal end [m]
  double cut_margin_m = 0.005;                ///< default cut: this far below the open rim's lowest point
  bool estimate_bones = true;                 ///< estimate bones when none are given
  /// Transfemoral: the stump reaches this far above the ischial tuberosity, so that an ischial
  /// containment (ICS: 45 mm above it postero-medially) or a quadrilateral brim (anterior wall
  /// 65 mm above the seat) fits below its top [m], [0.03, 0.15]. A scan that ends lower (the
  /// OpenLimbTF skin ends 105 mm below the tuberosity at the groin) is continued above its open
  /// rim by walls parallel to the axis (extend_skin_to_height), said in the notes and in
  /// LimbModel::skin_extension_m.
  double containment_height_m = 0.075;
  bool extend_skin = true;                    ///< false: never continue the skin above its rim
  /// Accept a limb whose size after units is outside the anatomical ranges of its type
  /// (check_limb_size); otherwise such a limb is refused with the likely unit mistake.
  bool force_size = false;
};

/// Fills in @p lo what the limb file states (@p info: an AAOP file's header) and the user did not
/// give: the side (LEFT / RIGHT). The file's landmarks are not used (geometry.md: the clinical
/// example's do not lie on its surface). Returns one note per value taken from the file.
std::vector<std::string> apply_file_hints(LimbInputOptions& lo, const geometry::MeshReadInfo& info);

/// The anatomical size ranges of a limb type, after units (check_limb_size). Lengths along the
/// limb axis from the distal end to the skin's highest point; widths are the diameter of the
/// circle of the same area as the section half-way up the skin's closed part.
struct LimbSizeRange {
  double min_length_m, max_length_m;
  double min_width_m, max_width_m;
};
/// Transtibial: length 60–450 mm, mid-width 50–200 mm; transfemoral: 50–600 mm, 70–250 mm.
/// Sources: the generator's ranges (transtibial residual 60–300 mm below the knee plus up to 120
/// mm above; transfemoral 100–450 mm below the ischial tuberosity plus up to 150 mm above, thigh
/// circumference at most 0.80 m at the tuberosity, i.e. 255 mm across, more than mid-thigh) with a
/// margin below; no real limb of ../shared/data is outside them (OpenLimbTF mean limb scaled by a
/// 0.45 m femur: 236 × 122 mm; unscaled, read as metres: 525 × 270 mm, refused).
LimbSizeRange limb_size_range(geometry::LimbType type);

/// The likely unit mistake of a limb that @p factor would bring to its anatomical size (1000: a
/// file in m read as mm; 1/1000: in mm read as m; 0.05–20: a normalised shape), as one phrase.
std::string unit_mistake_hint(double factor);

/// Measured size of a skin in its frame, and its check against the type's range.
struct LimbSize {
  double length_m = 0.0;  ///< distal end to the skin's highest point along the axis
  double width_m = 0.0;   ///< equivalent diameter of the mid-length section
};
LimbSize measure_limb_size(const geometry::TriMesh& skin, const geometry::LimbFrame& frame);
/// @throws InvalidInputError with one line naming the size, the range and the likely unit mistake
///         ("… 1000 x too large: the file is probably in mm; give units mm", "… a normalised
///         shape? give limb.scale …") when @p size is outside limb_size_range(@p type).
void check_limb_size(const LimbSize& size, geometry::LimbType type);

/// A limb ready for meshing.
struct LimbModel {
  geometry::LimbType type = geometry::LimbType::Transtibial;
  geometry::TriMesh skin;           ///< closed, outward, trimmed; cap triangles at the end
  int first_cap_triangle = -1;      ///< skin triangles from here on are the proximal cap
  std::vector<NamedMesh> bones;     ///< closed, trimmed at the cut, inside the skin
  bool bones_estimated = false;     ///< some bone was estimated (names end in "(estimated)")
  geometry::LimbFrame frame;
  double cut_height_m = 0.0;        ///< h of the proximal cut plane
  double length_m = 0.0;            ///< = cut_height_m (distal end at h = 0)
  /// How far the skin was continued above the scan's open rim (0: not at all) [m]: the largest
  /// height of added wall, measured from the rim to the cut.
  double skin_extension_m = 0.0;
  /// Share of the trimmed skin's side area that was added above the scan (0: none) [-].
  double skin_extension_area_fraction = 0.0;
  std::string axis_source;          ///< "given", "femur", "skin"
  std::string anterior_source;      ///< "given", "hemipelvis", "patella", "tibia", "skin"
  std::vector<Landmark> landmarks;
  /// Transfemoral: the bony points (from the file's femur and hemipelvis, or estimated) that the
  /// landmarks and the brims are placed from.
  std::optional<TransfemoralPoints> transfemoral;
  std::vector<std::string> notes;   ///< repairs and automatic decisions, one line each
};

/// Continues an open skin above its open rim with walls parallel to the axis: above every rim
/// vertex a column of new vertices, rows spaced about @p row_spacing_m, up to one plane at height
/// @p top_h_m of @p frame (raised to 1 mm above the rim's highest vertex when the rim reaches
/// above it). The new triangles join the rim edge to edge, with the skin's orientation; the new
/// top boundary is a planar loop. The added surface is an assumption (no scan data): callers say so.
/// @throws InvalidInputError when the skin has no open boundary or more than one boundary loop,
///         or a rim vertex is not star-shaped about the axis (two rim vertices at one angle).
struct SkinExtension {
  geometry::TriMesh skin;           ///< the skin with the walls (the original triangles first)
  int first_added_triangle = 0;
  double added_area_m2 = 0.0;
  double top_h_m = 0.0;             ///< height of the new open rim
};
SkinExtension extend_skin_to_height(const geometry::TriMesh& open_skin, const geometry::LimbFrame& frame,
                                    double top_h_m, double row_spacing_m = 0.004);

/// Prepares a limb. @p limb may hold the skin and bone shells; @p extra_bones (may be empty) holds
/// bones from a separate file. Shells are told apart by size and containment (the skin is the
/// shell of largest area; bones must lie inside it, except a transfemoral hemipelvis, which a CT
/// scan shows whole: it is kept where it lies inside the stump, at least 5 mm under the skin).
/// Transfemoral limbs: the femur is the most elongated bone shell, the hemipelvis the largest other
/// shell; the axis follows the femur's shaft, the front and the side come from the hemipelvis
/// (transfemoral_anatomy.h); either bone is estimated from the skin when absent.
/// @throws InvalidInputError / TopologyError with one line naming the problem and the fix: not
/// limb-like (sphere, box), holes that cannot be closed, bones outside the skin, a cut outside
/// the limb, a limb of implausible size (wrong units).
LimbModel prepare_limb(const geometry::TriMesh& limb, const geometry::TriMesh& extra_bones,
                       const LimbInputOptions& options = {});

/// The mesher's input for a prepared limb (closed skin with its cap, frame, cut, bone surfaces).
HexMesherInput mesher_input(const LimbModel& model);

}  // namespace socketsmith::volume
