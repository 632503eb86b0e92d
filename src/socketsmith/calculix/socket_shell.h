#pragma once
/// @file socket_shell.h
/// The designed socket as CalculiX's rigid shell for the donning check (check_design, Donning mode):
/// the stump's skin quads below the brim, split, laid on socketsmith's own wall when asked, moved
/// distally by the donning travel and extruded.

#include <array>
#include <vector>

#include "socketsmith/calculix/calculix_deck.h"
#include "socketsmith/calculix/design_check.h"

namespace socketsmith::calculix {

/// Per skin node: no socket there (above the socket's brim: DesignedStump::above_socket_brim, else
/// above_brim). @throws InvalidInputError when the socket's flags do not match the skin.
const std::vector<char>& outside_socket(const DesignedStump& d);

/// The skin quads (in local skin ids; @p skin_of maps mesh node → local skin id) that lie wholly
/// below the socket's brim (outside_socket): the socket's; @p across_brim: also those with a node below it (the shell laid on
/// socketsmith's wall reaches its rim and lip).
/// @throws InvalidInputError when no quad lies below the brim.
std::vector<std::array<int, 4>> socket_quads_below_brim(const DesignedStump& d, const std::vector<int>& skin_of,
                                                        bool across_brim);

/// The designed socket as a shell on @p socket_quads (at the closed loop's wall positions when
/// given), each quad split o.shell_subdivision², moved by @p down. With o.shell_on_wall every point
/// is laid on socketsmith's wall, and the quads across the brim, when given, land their points past
/// the rim on the lip (a point past the lip drops its quad).
/// The thickness is halved until no element is inverted (the lip curves tighter than the socket is
/// thick; the shell is rigid, its thickness does not count); a quad across the brim that folds over
/// the lip whatever the thickness is left out (one log line says how many).
/// @throws InvalidInputError when no quad faces the wall.
RigidShell donned_skin_shell(const DesignedStump& d, const std::vector<std::array<int, 4>>& socket_quads,
                             const Vec3& down, const DesignCheckOptions& o);

}  // namespace socketsmith::calculix
