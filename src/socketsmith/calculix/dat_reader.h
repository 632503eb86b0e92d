#pragma once
/// @file dat_reader.h
/// Reader of CalculiX's printed results (.dat): the blocks written by *NODE PRINT (e.g.
/// "displacements (vx,vy,vz) for set REF and time 0.25", "forces (fx,fy,fz) ...",
/// "total force (fx,fy,fz) ...") and *CONTACT PRINT's statistics ("statistics for slave set
/// SLIMB, master set SSOCK and time ...": total surface force and moment, centre, area, normal
/// and shear force).

#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

namespace socketsmith::calculix {

/// One printed block.
struct DatBlock {
  std::string title;  ///< the header before " for set" ("displacements (vx,vy,vz)", "statistics")
  std::string set;    ///< the set name ("REF", "BONE"; the slave set for contact statistics)
  double time = 0;    ///< total time of the increment
  /// Numeric rows in order. Node rows start with the node id; contact statistics have four rows:
  /// force and moment (6), centre and mean normal (6), moment about the centre (3),
  /// area, normal force (+ = tension) and shear force (3).
  std::vector<std::vector<double>> rows;
  /// The rows are in their node's local system (a *TRANSFORM: ccx ends such rows with "L"), not
  /// the global one — the reference node of a socket whose axis is not the global z.
  bool local = false;
};

/// Parses .dat text. @throws InvalidInputError naming the source and line on a malformed number.
std::vector<DatBlock> parse_dat(std::string_view text, const std::string& source = "dat");
/// @throws IoError when the file cannot be read; as parse_dat.
std::vector<DatBlock> read_dat(const std::filesystem::path& path);

/// The last block whose title starts with @p title_prefix, for @p set (case-insensitive);
/// null when there is none.
const DatBlock* last_block(const std::vector<DatBlock>& blocks, std::string_view title_prefix, std::string_view set);

/// The last block like last_block's whose increment ends at total time @p time (within 1e-9), e.g.
/// the end of step 1 (time 1); null when there is none.
const DatBlock* block_at(const std::vector<DatBlock>& blocks, std::string_view title_prefix, std::string_view set,
                         double time);

}  // namespace socketsmith::calculix
