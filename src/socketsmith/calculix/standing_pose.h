#pragma once
/// @file standing_pose.h
/// The thesis's second FE step, standing, read back from CalculiX: the socket moved up the limb axis
/// under displacement control (calculix_deck.h, FeSteps::stand_travel_m), the pose where the
/// reference node's reaction equals the standing load found between the printed increments, and
/// the push to run again with when it was not reached.

#include <limits>
#include <vector>

#include <Eigen/Core>

#include "socketsmith/calculix/dat_reader.h"

namespace socketsmith::calculix {

using Vec3 = Eigen::Vector3d;

/// CalculiX's standing step read from the reference node's printed reactions and displacements:
/// where the reaction along the load direction reaches the load.
struct StandingPose {
  double donned_force_n = std::numeric_limits<double>::quiet_NaN();  ///< at the end of step 1 (time 1); NaN: it never ended
  double last_time = 0;           ///< the furthest increment printed (total time; > 1 in step 2)
  double last_force_n = 0;        ///< its reaction [N]
  double last_displacement_m = 0;  ///< its reference node's displacement along the load direction [m]
  bool reached = false;           ///< two increments bracket the load (step 1's end counts)
  double time_a = 0, time_b = 0;  ///< those increments' total times (the first crossing)
  double weight = 0;              ///< of increment b, in [0, 1]: the state at the load is (1 − w) a + w b
  double displacement_m = 0;      ///< the reference node's displacement along the load at the load [m]
};
/// @p dat's reference node (set REF) in step 2 against @p load_n along the unit @p direction.
StandingPose standing_pose(const std::vector<DatBlock>& dat, double load_n, const Vec3& direction);

/// The standing travel to run step 2 again with [m] when @p pose did not reach @p load_n after a
/// push of @p travel_m: the other way when the donned socket already carried more (less) than the
/// load and the push went further on (back), as far as CalculiX's stiffness in the step asks for,
/// times 1.5; further the same way when the push ran to its end short of the load (the gain
/// extrapolated, times 1.5: 1.5 to 4 times the travel). NaN when a rerun would not help: step 1
/// never ended, or step 2 stopped (ccx gave up) short of the load on its way.
double standing_retry_travel_m(const StandingPose& pose, double travel_m, double load_n);

}  // namespace socketsmith::calculix
