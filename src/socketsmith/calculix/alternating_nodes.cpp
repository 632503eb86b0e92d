/// @file alternating_nodes.cpp
/// calculix::alternating_skin_nodes (design_check.h): the node-by-node alternation of a contact
/// pressure field, which `validate design` reruns ccx for.
#include "socketsmith/calculix/design_check.h"

#include <cmath>
#include <cstdlib>

#include "socketsmith/core/errors.h"

namespace socketsmith::calculix {

std::vector<char> alternating_skin_nodes(const std::vector<double>& fe, const std::vector<double>& design,
                                         const std::vector<std::vector<int>>& adj, const std::vector<int>& brim_ring,
                                         double margin_pa) {
  const size_t n = fe.size();
  require(design.size() == n && adj.size() == n && brim_ring.size() == n,
          "alternating_skin_nodes: fields of sizes {}, {}, {}, {} (expected one value per skin node)", n,
          design.size(), adj.size(), brim_ring.size());
  std::vector<char> out(n, 0);
  // A node's neighbours from the 2nd ring on: the socket's edge at the brim presses on the 1st.
  const auto off_neighbours = [&](const std::vector<double>& p, size_t i) {
    double mean = 0;
    int count = 0;
    for (int j : adj[i])
      if (brim_ring[j] >= 2) {
        mean += p[j];
        ++count;
      }
    return count > 0 ? p[i] - mean / count : 0.0;
  };
  for (size_t i = 0; i < n; ++i)
    if (brim_ring[i] >= 2)
      out[i] = std::abs(off_neighbours(fe, i)) - std::abs(off_neighbours(design, i)) > margin_pa ? 1 : 0;
  return out;
}

}  // namespace socketsmith::calculix
