#pragma once
/// @file brim.h
/// The socket's brim line (trim line): a closed curve h = brim(θ) on the limb, through editable
/// key points, interpolated by a periodic Akima spline (thesis ch. 5, docs/method.md §3). Forces above
/// the brim are removed from the design and the socket is cut along it.
///
/// Templates (placed from the landmarks; heights relative to the knee line k = POP.h + 10 mm and
/// the patellar-tendon height p = PT.h for transtibial limbs, the ischial seat i = IS.h and the
/// greater trochanter g = GT.h for transfemoral ones; values in docs/socket_builder.md):
/// - `ptb`: patellar-tendon bearing. Anterior at mid-patella (p + 30 mm), medial/lateral wings
///   to the femoral condyles (k + 20 mm), posterior low (p + 10 mm) with lower hamstring reliefs
///   so the knee can flex.
/// - `ptb-sc`: supracondylar — as PTB with the wings over the condyles (k + 50 mm), for
///   medio-lateral stability and suspension.
/// - `ptb-scsp`: supracondylar-suprapatellar — also the anterior brim above the patella (k + 55 mm).
/// - `kbm`: Kondylen-Bettung Münster — high medial/lateral wings (k + 50 mm) gripping the
///   condyles, the patella left free (anterior p + 10 mm).
/// - `tsb`: total surface bearing — a nearly level brim high all around (k + 25…30 mm), slightly
///   lower posteriorly (k + 5 mm).
/// - `quad`: transfemoral quadrilateral — a level posterior ischial seat at IS (the tuberosity
///   sits on it), the medial wall at the same level, the anterior wall 65 mm higher over Scarpa's
///   triangle (holding the tuberosity back on the seat), the lateral wall up to the trochanter.
/// - `ics`: ischial(-ramal) containment — the postero-medial brim 50 mm above IS wraps the
///   tuberosity and the ramus (35 mm above IS between them and the adductor longus), a relief down
///   to IS + 5 mm over the adductor longus tendon, the lateral wall 15 mm over the trochanter
///   (at most IS + 45 mm, so that the containment stays the highest point).
/// Transfemoral key points sit at the landmarks' angles (IS, AL, ST, GT), not at fixed ones.
/// Every template height is clamped to [min_height_fraction · cut, cut − top_margin] (said in the
/// notes of make_brim).

#include <string>
#include <vector>

#include <Eigen/Core>

#include "socketsmith/geometry/akima_spline.h"
#include "socketsmith/geometry/limb_frame.h"
#include "socketsmith/geometry/tri_mesh.h"
#include "socketsmith/volume/landmarks.h"
#include "socketsmith/volume/limb_model.h"

namespace socketsmith::design {

/// Socket types with a brim template; Custom = key points given explicitly (case file).
enum class BrimTemplate { Ptb, PtbSc, PtbScsp, Kbm, Tsb, Quad, Ics, Custom };

/// "ptb" | "ptb-sc" | "ptb-scsp" | "kbm" | "tsb" | "quad" | "ics" | "custom".
std::string to_string(BrimTemplate kind);
/// Inverse of to_string, case-insensitive ("PTB-SC" works); "quadrilateral" is read as quad.
/// @throws InvalidInputError naming the text and listing the valid names.
BrimTemplate parse_brim_template(const std::string& text);
/// The limb type a template is made for (Custom: none — throws InvalidInputError).
geometry::LimbType limb_type_of(BrimTemplate kind);

/// One key point of the brim.
struct BrimKeyPoint {
  std::string label;   ///< e.g. "anterior (mid-patella)"; free text, may be empty
  double theta = 0.0;  ///< [rad], from anterior towards medial (any value; wrapped)
  double h = 0.0;      ///< height above the distal end [m]
};

/// A closed brim line h = height(θ) through key points (periodic Akima spline in θ).
class BrimLine {
 public:
  BrimLine() = default;
  /// @throws InvalidInputError (message starting "brim line:") when fewer than 3 key points, a
  ///         non-finite value, or two key points at the same angle.
  BrimLine(BrimTemplate kind, std::vector<BrimKeyPoint> key_points);

  BrimTemplate kind() const { return kind_; }
  std::string name() const { return to_string(kind_); }
  /// Key points in the order given (not sorted).
  const std::vector<BrimKeyPoint>& key_points() const { return points_; }
  const geometry::PeriodicAkimaSpline& spline() const { return spline_; }

  /// Brim height at angle @p theta [m] (θ in rad, any value).
  double height(double theta) const { return spline_.value(theta); }
  /// d height / d θ [m/rad].
  double slope(double theta) const { return spline_.derivative(theta); }
  /// Lowest and highest point of the curve (sampled every 0.5°) [m].
  double min_height() const;
  double max_height() const;

  /// Moves key point @p index to (θ [rad], h [m]) and rebuilds the spline. The kind stays (a
  /// report can say "ptb, edited"); is_edited() becomes true.
  /// @throws InvalidInputError for an index out of range or an invalid resulting curve (the line
  ///         is left unchanged).
  void move_key_point(int index, double theta, double h);
  /// Replaces every key point (same rules as the constructor; unchanged on error).
  void set_key_points(std::vector<BrimKeyPoint> key_points);
  bool is_edited() const { return edited_; }

 private:
  BrimTemplate kind_ = BrimTemplate::Custom;
  std::vector<BrimKeyPoint> points_;
  geometry::PeriodicAkimaSpline spline_;
  bool edited_ = false;
};

/// Placement of the templates.
struct BrimOptions {
  double top_margin_m = 0.005;        ///< key points at most cut − this [m], ≥ 0 (the mesh ends at the cut)
  double min_height_fraction = 0.4;   ///< key points at least this × cut height, in [0, 1)
};

/// The template @p kind placed on a limb from its landmarks (codes PT, POP for transtibial; IS,
/// GT, AL, ST for transfemoral) and its cut height [m]. When a key point has to be clamped into the
/// stump (a scan that ends too low), one line per key point is appended to @p notes.
/// @throws InvalidInputError when the template is for the other limb type ("brim 'quad' is a
///         transfemoral template but the limb is transtibial; use one of ptb, ..."), a needed
///         landmark is missing, Custom is asked for, or options are out of range.
BrimLine make_brim(BrimTemplate kind, geometry::LimbType type, const std::vector<volume::Landmark>& landmarks,
                   double cut_height_m, const BrimOptions& options = {}, std::vector<std::string>* notes = nullptr);
/// Same, from a prepared limb model (its type, landmarks and cut height).
BrimLine make_brim(BrimTemplate kind, const volume::LimbModel& model, const BrimOptions& options = {},
                   std::vector<std::string>* notes = nullptr);

/// The brim a limb type gets when the case names none: PTB (transtibial), ICS (transfemoral).
BrimTemplate default_brim(geometry::LimbType type);

/// A brim from explicit key points (case file). @throws as the BrimLine constructor.
BrimLine brim_from_key_points(std::vector<BrimKeyPoint> key_points, BrimTemplate kind = BrimTemplate::Custom);

/// Where a brim must rise: at angle theta [rad] by at least lift_m [m].
struct BrimLift {
  double theta = 0.0;
  double lift_m = 0.0;
};

/// The largest of @p lifts at angle @p theta: each lift in full within @p plateau_rad of its angle,
/// then easing (cos²) to nothing over another @p plateau_rad [m] (raise_brim's profile).
double eased_lift(const std::vector<BrimLift>& lifts, double plateau_rad, double theta);

/// @p brim raised locally: by the largest lift whose angle lies within @p plateau_rad, then easing
/// (cos²) to nothing over another @p plateau_rad, and never above @p max_height_m (where the brim
/// already lies above it, it stays). The result is sampled every 2.5° (144 key points, labelled
/// "raised"), keeps the brim's kind, and equals @p brim within 0.1 mm where nothing lifts it (the
/// Akima spline through samples of a smooth curve). No positive lift: @p brim unchanged.
/// @throws InvalidInputError for a non-finite lift or a plateau outside (0, π/2].
BrimLine raise_brim(const BrimLine& brim, const std::vector<BrimLift>& lifts, double plateau_rad, double max_height_m);

/// Limits of validate_brim.
struct BrimValidationOptions {
  double top_margin_m = 0.0;            ///< key points must lie at least this below the skin's top [m]
  double min_enclosed_fraction = 0.5;   ///< skin area below the brim / side area of the skin, (0, 1]
};

/// Checks a brim against the skin it will cut (@p skin: the limb's skin, closed with a flat cap in
/// the cut plane or open at the top; its top is the highest vertex in the frame).
/// @throws InvalidInputError with one line naming the key point and the fix when a key point is
///         above the skin's top ("a brim above the skin") or at/below the distal end (h ≤ 0), or
///         when less than min_enclosed_fraction of the skin lies below the brim.
void validate_brim(const BrimLine& brim, const geometry::TriMesh& skin, const geometry::LimbFrame& frame,
                   const BrimValidationOptions& options = {});

/// True when @p p lies above the brim: its h exceeds brim.height(θ) in @p frame.
bool above_brim(const BrimLine& brim, const Eigen::Vector3d& p, const geometry::LimbFrame& frame);

/// above_brim for every point (1 = above, 0 = at or below), e.g. the skin nodes of a design.
std::vector<char> points_above_brim(const BrimLine& brim, const std::vector<Eigen::Vector3d>& points,
                                    const geometry::LimbFrame& frame);

}  // namespace socketsmith::design
