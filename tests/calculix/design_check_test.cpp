#include "socketsmith/calculix/design_check.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include <gtest/gtest.h>

#include "socketsmith/core/errors.h"

namespace socketsmith::calculix {
namespace {

/// A rows × cols grid of skin nodes with edge neighbours; row r is r rings below the brim.
struct Grid {
  int rows, cols;
  std::vector<std::vector<int>> adj;
  std::vector<int> ring;
  Grid(int r, int c) : rows(r), cols(c), adj(r * c), ring(r * c) {
    for (int i = 0; i < r; ++i)
      for (int j = 0; j < c; ++j) {
        const int k = i * c + j;
        ring[k] = i;
        if (i > 0) adj[k].push_back(k - c);
        if (i + 1 < r) adj[k].push_back(k + c);
        if (j > 0) adj[k].push_back(k - 1);
        if (j + 1 < c) adj[k].push_back(k + 1);
      }
  }
  int at(int i, int j) const { return i * cols + j; }
  /// A pressure crest along column @p col: @p peak there, falling off with the distance [Pa].
  std::vector<double> crest(int col, double peak, double width) const {
    std::vector<double> p(rows * cols);
    for (int i = 0; i < rows; ++i)
      for (int j = 0; j < cols; ++j) p[at(i, j)] = peak * std::exp(-std::pow((j - col) / width, 2));
    return p;
  }
};

int count(const std::vector<char>& flags) { return static_cast<int>(std::count(flags.begin(), flags.end(), char{1})); }

TEST(AlternatingSkinNodes, a_smooth_crest_higher_than_designed_is_not_alternation) {
  const Grid g(12, 12);
  const auto design = g.crest(6, 15e3, 2.0);
  auto fe = g.crest(6, 21e3, 1.5);  // 40 % higher and narrower: a gap, not node-by-node alternation
  for (auto& p : fe) p += 2e3;
  EXPECT_EQ(count(alternating_skin_nodes(fe, design, g.adj, g.ring, 5e3)), 0);
}

TEST(AlternatingSkinNodes, pressures_alternating_along_a_crest_are_found_where_the_design_is_smooth) {
  // The AAOP example's anterior crest in one 5 % CalculiX try: contact lost on some nodes (0-2 kPa)
  // and 25-32 kPa on the next, where the design (and socketsmith) put a smooth 11-18 kPa.
  const Grid g(12, 12);
  const auto design = g.crest(6, 15e3, 2.0);
  auto fe = design;
  for (int i = 4; i < 10; ++i) fe[g.at(i, 6)] = i % 2 ? 27e3 : 0.1e3;
  const auto flags = alternating_skin_nodes(fe, design, g.adj, g.ring, 5e3);
  EXPECT_EQ(count(flags), 6);
  for (int i = 4; i < 10; ++i) EXPECT_EQ(flags[g.at(i, 6)], 1) << "row " << i;
}

TEST(AlternatingSkinNodes, a_spike_the_design_has_too_and_the_brim_are_left_alone) {
  const Grid g(12, 12);
  auto design = g.crest(6, 15e3, 2.0);
  design[g.at(8, 3)] += 20e3;  // a designed relief's opposite: a loaded spot one node wide
  auto fe = design;
  fe[g.at(8, 3)] += 2e3;
  fe[g.at(1, 2)] += 30e3;  // one ring below the brim, and its neighbours: where the socket's edge presses
  EXPECT_EQ(count(alternating_skin_nodes(fe, design, g.adj, g.ring, 5e3)), 0);
  fe[g.at(3, 2)] -= 12e3;  // a pit the design does not have
  const auto flags = alternating_skin_nodes(fe, design, g.adj, g.ring, 5e3);
  EXPECT_EQ(count(flags), 1);
  EXPECT_EQ(flags[g.at(3, 2)], 1);
}

TEST(AlternatingSkinNodes, fields_of_other_sizes_are_an_error) {
  const Grid g(4, 4);
  const auto p = g.crest(2, 10e3, 1.0);
  EXPECT_THROW(alternating_skin_nodes(p, std::vector<double>(3, 0.0), g.adj, g.ring, 5e3), InvalidInputError);
}

}  // namespace
}  // namespace socketsmith::calculix
