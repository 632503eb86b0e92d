#pragma once
/// @file csv.h
/// Numeric CSV tables: one header line of column names, then rows of numbers. Written
/// atomically; the reader is small and strict (for tests and tools, not a general CSV parser).

#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

namespace socketsmith::report {

/// Writes a numeric table as CSV: a header line, then one line per row, values separated by
/// commas and written with @p significant_digits significant digits ("%.*g"). Non-finite values
/// are written as "nan", "inf", "-inf" (read_csv reads them back). Column names that contain a
/// comma, a quote or surrounding spaces are quoted (RFC 4180).
/// @param path   target file, written atomically (temporary file + rename)
/// @param header column names; may be empty (then no header line is written and every row
///               must have the width of the first row)
/// @param rows   #rows×#columns values
/// @param significant_digits in [1, 17]
/// @throws InvalidInputError when a row's width differs from the header's (naming the row),
///         a column name contains a line break, or @p significant_digits is out of range;
///         IoError when the file cannot be written.
void write_csv(const std::filesystem::path& path, const std::vector<std::string>& header,
               const std::vector<std::vector<double>>& rows, int significant_digits = 10);

/// A numeric table read back from CSV.
struct CsvTable {
  std::vector<std::string> header;        ///< column names
  std::vector<std::vector<double>> rows;  ///< #rows×#columns values

  int num_columns() const { return static_cast<int>(header.size()); }
  int num_rows() const { return static_cast<int>(rows.size()); }
  /// Index of the column named @p name, or -1 when there is none.
  int column_index(std::string_view name) const;
  /// All values of the column named @p name.
  /// @throws InvalidInputError when there is no such column (listing the available ones).
  std::vector<double> column(std::string_view name) const;
};

/// Reads a CSV file written by write_csv (or any CSV with one header line and numeric cells).
/// Blank lines are skipped; "\r\n" line ends are accepted; cells may be surrounded by spaces.
/// @throws IoError when the file cannot be opened; InvalidInputError naming the file and the
///         line number when the file is empty, a row has the wrong number of cells or a cell
///         is not a number.
CsvTable read_csv(const std::filesystem::path& path);

}  // namespace socketsmith::report
