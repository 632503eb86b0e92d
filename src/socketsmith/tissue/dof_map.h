#pragma once
/// @file dof_map.h
/// Kinematic constraints on nodal degrees of freedom, by reduced coordinates: x = x_p + P q,
/// where fixed DOFs have no column in P (Dirichlet, held at their value in x_p) and the DOFs of
/// a tied group share one column (they move together, e.g. nodes under a rigid box).
/// Reduced forces are Pᵀ f and reduced matrices Pᵀ A P.

#include <string_view>
#include <vector>

#include <Eigen/Core>
#include <Eigen/SparseCore>

#include "socketsmith/volume/hex_mesh.h"

namespace socketsmith::tissue {

using Eigen::VectorXd;
using SparseMatrix = Eigen::SparseMatrix<double>;

/// DOF index of node @p node, axis @p axis (0 = x, 1 = y, 2 = z).
inline int dof(int node, int axis) { return 3 * node + axis; }

/// Constraints in full-DOF indices.
struct DofConstraints {
  std::vector<int> fixed;                     ///< DOFs held at their current value
  std::vector<std::vector<int>> tied_groups;  ///< each group moves by one shared displacement

  /// Fixes all three DOFs of every node in @p nodes.
  void fix_nodes(const std::vector<int>& nodes);
};

/// The map between full (3N) and reduced coordinates.
class DofMap {
 public:
  /// @throws InvalidInputError when a DOF is out of range, or is both fixed and tied, or
  ///         belongs to two groups.
  DofMap(int num_full_dofs, const DofConstraints& constraints);

  int num_full() const { return static_cast<int>(reduced_index_.size()); }
  int num_reduced() const { return num_reduced_; }
  /// Reduced index of each full DOF, −1 when fixed.
  const std::vector<int>& reduced_index() const { return reduced_index_; }
  bool is_fixed(int full_dof) const { return reduced_index_[full_dof] < 0; }

  /// Pᵀ v: sums the entries of tied DOFs, drops fixed ones.
  VectorXd restrict_vector(const VectorXd& full) const;
  /// full += P q.
  void add_expanded(const VectorXd& reduced, VectorXd& full) const;
  /// Pᵀ A P for a square full matrix. The reduced pattern is built on the first call and
  /// reused while A keeps the same pattern (a model's Jacobians always do).
  void reduce_matrix(const SparseMatrix& full, SparseMatrix& reduced) const;

 private:
  std::vector<int> reduced_index_;
  int num_reduced_ = 0;
  // cache for reduce_matrix
  mutable const int* cached_outer_ = nullptr;
  mutable Eigen::Index cached_nnz_ = -1;
  mutable std::vector<int> cached_outer_copy_, cached_inner_copy_;  // the cached full pattern
  mutable std::vector<int> value_map_;  // full value index -> reduced value index or -1
  mutable SparseMatrix reduced_pattern_;
};

/// The DofMap of a meshed stump: every node tagged kNodeFixed (bones, proximal cut) held.
/// @throws InvalidInputError naming @p what when no node is fixed (the problem would be singular).
DofMap fixed_node_dofs(const volume::HexMesh& mesh, std::string_view what);

}  // namespace socketsmith::tissue
