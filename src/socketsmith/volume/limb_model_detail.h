#pragma once
/// The steps of `prepare_limb` (inside `volume` only; `limb_model.h` is the interface):
/// - reading the shells, orienting the limb, choosing the cut and trimming the skin
///   (`limb_model.cpp`);
/// - the bones inside the trimmed stump: trimmed, checked against the skin, named, and estimated
///   where the file has none (`limb_bones.cpp`).
/// Why apart: the bones come after the skin is settled and are a responsibility of their own; they
/// share the state below, and the transtibial front, which is read from the named bones.

#include <optional>
#include <utility>
#include <vector>

#include "socketsmith/volume/limb_model.h"
#include "socketsmith/volume/limb_shells.h"
#include "socketsmith/volume/transfemoral_anatomy.h"

namespace socketsmith::volume::limb_model_detail {

using limb_shells::Shell;

/// What prepare_limb's steps share: the options, the model being built, the skin and the other
/// shells of the file, the transfemoral bones' roles and directions, and the heights found on the way.
struct LimbPreparation {
  explicit LimbPreparation(const LimbInputOptions& options)
      : opt(options), tf(options.type == geometry::LimbType::Transfemoral) {
    model.type = options.type;
  }

  const LimbInputOptions& opt;
  bool tf = false;  ///< a transfemoral limb
  LimbModel model;
  Shell skin;                       ///< the shell of largest area, until it is trimmed into model.skin
  std::vector<Shell> shells;        ///< the other shells: bones, or debris
  int femur_i = -1, pelvis_i = -1;  ///< the transfemoral roles in shells (-1: absent)
  std::optional<FemurAxis> femur_axis;
  std::optional<PelvicDirections> pelvic;
  double rim = 0.0;                              ///< the open rim's lowest point above the distal end [m]
  std::vector<std::pair<double, double>> rim_h;  ///< the open rim as (θ, h), sorted by θ
  double ischial_h = -1.0;                       ///< the ischial tuberosity's height (-1: not known) [m]
  double cut = 0.0;                              ///< height of the proximal cut plane [m]
  std::optional<TransfemoralPoints> tf_points;
};

/// Front and side of p.model.frame: the user's, then bones, then the skin — once the bones are
/// named (transtibial: after the cut, as their names depend on it; transfemoral: before, as the
/// cut depends on them). @p named: the named bone shells; @p top: the height [m] whose 60 % gives
/// the skin section that the tibia's offset is measured from. (limb_model.cpp)
void decide_front(LimbPreparation& p, const std::vector<Shell>& named, const geometry::TriMesh& skin_mesh,
                  double top);

/// The bones of p.model, after the skin is trimmed: the file's bone shells trimmed at the cut and
/// checked to lie inside the skin (the hemipelvis: clipped to the stump), named, and those the file
/// lacks estimated from the skin when p.opt asks for it; sets p.tf_points for estimated
/// transfemoral bones. (limb_bones.cpp)
void place_bones(LimbPreparation& p);

}  // namespace socketsmith::volume::limb_model_detail
