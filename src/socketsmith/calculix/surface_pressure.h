#pragma once
/// @file surface_pressure.h
/// The contact pressure of an FE solution from the body's own stress: p = −n·σ·n at each surface
/// node, with σ CalculiX's nodal (Cauchy, under NLGEOM) stress and n the node's outward normal on
/// the deformed surface (area-weighted over its faces).
///
/// Why not CalculiX's nodal CPRESS: with penalty surface-to-surface contact against a faceted
/// rigid socket, CPRESS is K × the penetration extrapolated from the integration points, and with
/// a stiff penalty (1e9 Pa/m: 0.1 mm = 100 kPa) it follows sub-0.2-mm differences of where a skin
/// node sits on the socket's facets. The demo's frictionless donning (1.8k nodes, ν 0.25) ended in
/// the same state from 30 and 60 mm below (skin displacements within 0.044 mm on average, contact
/// force 88.2 vs 90.1 N) but its CPRESS differed node by node (R 0.68 between the two runs, mean
/// 11.7 vs 16.0 kPa); −n·σ·n gave 9.03 vs 9.06 kPa, R 0.997 (docs/validation_fe.md).

#include <vector>

#include "socketsmith/calculix/calculix_deck.h"
#include "socketsmith/calculix/dat_reader.h"
#include "socketsmith/calculix/frd_reader.h"
#include "socketsmith/volume/hex_mesh.h"

namespace socketsmith::calculix {

/// Outward unit normals of the deformed surface at @p nodes (mesh ids): for each node the sum
/// of the area vectors of the @p faces that use it (a quarter of each face's area vector, the face
/// oriented away from its hexahedron's centre), normalised; zero for a node on none of them.
/// @param positions deformed position of every mesh node [m].
/// @param areas when given: each node's area, a quarter of the area of each face that uses it [m²].
/// @throws InvalidInputError when sizes or indices do not match the mesh.
std::vector<Vec3> deformed_surface_normals(const volume::HexMesh& mesh, const std::vector<Vec3>& positions,
                                           const std::vector<HexFace>& faces, const std::vector<int>& nodes,
                                           std::vector<double>* areas = nullptr);

/// −n·σ·n [Pa] at each of @p nodes (mesh ids; CalculiX id = mesh id + 1) from an frd STRESS block
/// (SXX, SYY, SZZ, SXY, SYZ, SZX) and the nodes' unit normals; positive in compression. 0 for a
/// node with a zero normal.
/// @throws InvalidInputError when the block lacks a stress component or the sizes differ.
std::vector<double> normal_surface_pressure(const FrdBlock& stress, const std::vector<int>& nodes,
                                            const std::vector<Vec3>& normals, int num_mesh_nodes);

/// The contact pressure as the FE's own nodal force balance: at each of @p nodes (mesh ids) the
/// internal force of the stump f_a = Σ_e Σ_g σ_g ∇ₓN_a det Jₓ (the deformed elements around the
/// node, CalculiX's Cauchy stress σ_g at each integration point), and p = −n·f / A, positive in
/// compression. At a free skin node f is what the socket pushes with, so p is the same quantity as
/// a designed pressure (a nodal force over a nodal area); unlike −n·σ·n it needs no extrapolation
/// of the stress to the surface, where a stiff skin layer makes nodal stresses scatter.
/// @param positions deformed position of every mesh node [m].
/// @param stresses the .dat block "stresses (elem, integ.pnt.,sxx,syy,szz,sxy,sxz,syz)": rows
///        (element id = hexahedron + 1, integration point 1..8 in CalculiX's order — ξ fastest, then
///        η, then ζ — or 1 for a reduced-integration element, then the six components).
/// @param normals,areas the nodes' deformed outward unit normals and areas [m²].
/// @param forces when given, the force f at each of @p nodes [N] (what the socket pushes with: its
///        normal part −p A n, the rest friction).
/// @throws InvalidInputError when a row's element or point is out of range, a used element has
///         rows missing, or the sizes differ.
std::vector<double> nodal_force_pressure(const volume::HexMesh& mesh, const std::vector<Vec3>& positions,
                                         const DatBlock& stresses, const std::vector<int>& nodes,
                                         const std::vector<Vec3>& normals, const std::vector<double>& areas,
                                         std::vector<Vec3>* forces = nullptr);

}  // namespace socketsmith::calculix
