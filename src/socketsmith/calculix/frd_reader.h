#pragma once
/// @file frd_reader.h
/// Reader of CalculiX's ASCII result file (.frd): node coordinates and the nodal result blocks
/// (DISP: D1..D3; CONTACT: COPEN, CSLIP1, CSLIP2, CPRESS, CSHEAR1, CSHEAR2; STRESS; ...) of every
/// increment. Fixed-width records: " -1", node id in 10 columns, values in 12 columns each; a
/// "-2" record continues the previous node's values.

#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include <Eigen/Core>

namespace socketsmith::calculix {

/// One nodal result block of one increment.
struct FrdBlock {
  std::string name;                     ///< "DISP", "CONTACT", "STRESS", ...
  std::vector<std::string> components;  ///< "D1", "D2", "D3" / "COPEN", ..., "CPRESS", ...
  int step = 0;                         ///< analysis step (1-based)
  int increment = 0;                    ///< increment within the step (1-based)
  double time = 0;                      ///< total time of the increment (steps of length 1: step − 1 + step time)
  std::vector<int> node_ids;            ///< CalculiX node ids (1-based)
  std::vector<double> values;           ///< node_ids.size() × components.size(), row-major

  int component_index(std::string_view component) const;  ///< -1 when absent
  /// Dense values of @p component for node ids 1..@p num_nodes (index id − 1; 0 where the block
  /// has no value). @throws InvalidInputError when the component is absent (naming the ones present).
  std::vector<double> dense(std::string_view component, int num_nodes) const;
};

/// A parsed .frd file.
struct FrdResults {
  std::vector<int> node_ids;              ///< as in the file's node block
  std::vector<Eigen::Vector3d> node_positions;
  std::vector<FrdBlock> blocks;           ///< in file order
  /// The last block named @p name (of step @p step when step > 0); null when there is none.
  const FrdBlock* last(std::string_view name, int step = 0) const;
};

/// Parses .frd text. @param source a name for messages (the file name).
/// @throws InvalidInputError naming the source and line when a record is malformed.
FrdResults parse_frd(std::string_view text, const std::string& source = "frd");

/// Reads and parses an .frd file. @throws IoError when it cannot be read; as parse_frd.
FrdResults read_frd(const std::filesystem::path& path);

}  // namespace socketsmith::calculix
