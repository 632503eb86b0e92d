#include "socketsmith/tissue/dof_map.h"

#include <algorithm>

#include "socketsmith/core/errors.h"

namespace socketsmith::tissue {

void DofConstraints::fix_nodes(const std::vector<int>& nodes) {
  for (int n : nodes)
    for (int a = 0; a < 3; ++a) fixed.push_back(dof(n, a));
}

DofMap::DofMap(int num_full_dofs, const DofConstraints& c) {
  require(num_full_dofs > 0, "DofMap: {} DOFs (expected > 0)", num_full_dofs);
  constexpr int kUnset = -2, kFixed = -1;
  std::vector<int> group_of(num_full_dofs, kUnset);
  for (int d : c.fixed) {
    require(d >= 0 && d < num_full_dofs, "DofMap: fixed DOF {} out of range [0, {})", d, num_full_dofs);
    group_of[d] = kFixed;
  }
  for (size_t g = 0; g < c.tied_groups.size(); ++g)
    for (int d : c.tied_groups[g]) {
      require(d >= 0 && d < num_full_dofs, "DofMap: tied DOF {} out of range [0, {})", d, num_full_dofs);
      require(group_of[d] == kUnset, "DofMap: DOF {} (node {}, axis {}) is in a tied group and also fixed or tied "
              "elsewhere", d, d / 3, d % 3);
      group_of[d] = static_cast<int>(num_full_dofs + g);  // marker, replaced below
    }
  reduced_index_.assign(num_full_dofs, -1);
  std::vector<int> group_index(c.tied_groups.size(), -1);
  for (int d = 0; d < num_full_dofs; ++d) {
    if (group_of[d] == kFixed) continue;
    if (group_of[d] == kUnset) {
      reduced_index_[d] = num_reduced_++;
    } else {
      int& gi = group_index[group_of[d] - num_full_dofs];
      if (gi < 0) gi = num_reduced_++;
      reduced_index_[d] = gi;
    }
  }
  require(num_reduced_ > 0, "DofMap: every DOF is fixed (nothing left to solve for)");
}

VectorXd DofMap::restrict_vector(const VectorXd& full) const {
  SOCKETSMITH_ASSERT(full.size() == num_full());
  VectorXd r = VectorXd::Zero(num_reduced_);
  for (int d = 0; d < num_full(); ++d)
    if (reduced_index_[d] >= 0) r[reduced_index_[d]] += full[d];
  return r;
}

void DofMap::add_expanded(const VectorXd& reduced, VectorXd& full) const {
  SOCKETSMITH_ASSERT(reduced.size() == num_reduced_ && full.size() == num_full());
  for (int d = 0; d < num_full(); ++d)
    if (reduced_index_[d] >= 0) full[d] += reduced[reduced_index_[d]];
}

void DofMap::reduce_matrix(const SparseMatrix& full, SparseMatrix& reduced) const {
  SOCKETSMITH_ASSERT(full.rows() == num_full() && full.cols() == num_full() && full.isCompressed());
  // Same pattern as the cached one? Pointers differ between matrices copied from one pattern
  // (a model's J, K and D), so compare the index arrays themselves when they do.
  const bool same_pattern =
      cached_nnz_ == full.nonZeros() &&
      (cached_outer_ == full.outerIndexPtr() ||
       (std::equal(full.outerIndexPtr(), full.outerIndexPtr() + full.outerSize() + 1, cached_outer_copy_.begin()) &&
        std::equal(full.innerIndexPtr(), full.innerIndexPtr() + full.nonZeros(), cached_inner_copy_.begin())));
  if (same_pattern) cached_outer_ = full.outerIndexPtr();
  if (!same_pattern) {
    // Build the reduced pattern and the value map once per full pattern.
    std::vector<Eigen::Triplet<double>> trips;
    trips.reserve(static_cast<size_t>(full.nonZeros()));
    for (int c = 0; c < full.outerSize(); ++c) {
      const int rc = reduced_index_[c];
      if (rc < 0) continue;
      for (SparseMatrix::InnerIterator it(full, c); it; ++it) {
        const int rr = reduced_index_[it.row()];
        if (rr >= 0) trips.emplace_back(rr, rc, 0.0);
      }
    }
    reduced_pattern_.resize(num_reduced_, num_reduced_);
    reduced_pattern_.setFromTriplets(trips.begin(), trips.end());
    reduced_pattern_.makeCompressed();
    value_map_.assign(static_cast<size_t>(full.nonZeros()), -1);
    for (int c = 0; c < full.outerSize(); ++c) {
      const int rc = reduced_index_[c];
      if (rc < 0) continue;
      const int* rbegin = reduced_pattern_.innerIndexPtr() + reduced_pattern_.outerIndexPtr()[rc];
      const int* rend = reduced_pattern_.innerIndexPtr() + reduced_pattern_.outerIndexPtr()[rc + 1];
      for (Eigen::Index k = full.outerIndexPtr()[c]; k < full.outerIndexPtr()[c + 1]; ++k) {
        const int rr = reduced_index_[full.innerIndexPtr()[k]];
        if (rr < 0) continue;
        const int* it = std::lower_bound(rbegin, rend, rr);
        value_map_[k] = static_cast<int>(it - reduced_pattern_.innerIndexPtr());
      }
    }
    cached_outer_ = full.outerIndexPtr();
    cached_nnz_ = full.nonZeros();
    cached_outer_copy_.assign(full.outerIndexPtr(), full.outerIndexPtr() + full.outerSize() + 1);
    cached_inner_copy_.assign(full.innerIndexPtr(), full.innerIndexPtr() + full.nonZeros());
  }
  if (reduced.nonZeros() != reduced_pattern_.nonZeros() || reduced.rows() != num_reduced_) reduced = reduced_pattern_;
  double* rv = reduced.valuePtr();
  std::fill(rv, rv + reduced.nonZeros(), 0.0);
  const double* fv = full.valuePtr();
  for (Eigen::Index k = 0; k < full.nonZeros(); ++k)
    if (value_map_[k] >= 0) rv[value_map_[k]] += fv[k];
}

DofMap fixed_node_dofs(const volume::HexMesh& mesh, std::string_view what) {
  std::vector<int> fixed;
  for (int n = 0; n < mesh.num_nodes(); ++n)
    if (mesh.has_tag(n, volume::kNodeFixed)) fixed.push_back(n);
  require(!fixed.empty(),
          "{}: the stump mesh has no fixed node (bones or proximal cut), so it is free to move away: mesh the limb "
          "with its bones",
          what);
  DofConstraints cons;
  cons.fix_nodes(fixed);
  return DofMap(3 * mesh.num_nodes(), cons);
}

}  // namespace socketsmith::tissue
