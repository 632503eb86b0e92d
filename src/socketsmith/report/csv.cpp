#include "socketsmith/report/csv.h"

#include <charconv>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <ostream>
#include <string>
#include <system_error>

#include "socketsmith/core/atomic_file.h"
#include "socketsmith/core/errors.h"

namespace socketsmith::report {
namespace {

bool needs_quotes(std::string_view name) {
  if (name.find_first_of(",\"") != std::string_view::npos) return true;
  return !name.empty() &&
         (name.front() == ' ' || name.front() == '\t' || name.back() == ' ' || name.back() == '\t');
}

std::string quote_if_needed(std::string_view name) {
  if (!needs_quotes(name)) return std::string(name);
  std::string out = "\"";
  for (char c : name) {
    if (c == '"') out += '"';  // RFC 4180: a quote inside a quoted field is doubled
    out += c;
  }
  out += '"';
  return out;
}

void write_value(std::ostream& out, double v, int digits) {
  // Non-finite values get a fixed spelling so the file does not depend on the C library.
  if (std::isnan(v)) {
    out << "nan";
  } else if (std::isinf(v)) {
    out << (v > 0 ? "inf" : "-inf");
  } else {
    out << fmt::format("{:.{}g}", v, digits);
  }
}

std::string_view trim(std::string_view s) {
  const auto first = s.find_first_not_of(" \t");
  if (first == std::string_view::npos) return {};
  const auto last = s.find_last_not_of(" \t");
  return s.substr(first, last - first + 1);
}

/// Splits one line into cells, honouring RFC 4180 quotes (without line breaks inside quotes).
/// Returns false on an unterminated quote.
bool split_line(std::string_view line, std::vector<std::string>& cells) {
  cells.clear();
  std::string cell;
  std::size_t i = 0;
  while (true) {
    // Skip leading blanks of the cell, then look for a quoted cell.
    std::size_t j = i;
    while (j < line.size() && (line[j] == ' ' || line[j] == '\t')) ++j;
    cell.clear();
    if (j < line.size() && line[j] == '"') {
      ++j;
      bool closed = false;
      while (j < line.size()) {
        if (line[j] == '"') {
          if (j + 1 < line.size() && line[j + 1] == '"') {
            cell += '"';
            j += 2;
          } else {
            closed = true;
            ++j;
            break;
          }
        } else {
          cell += line[j++];
        }
      }
      if (!closed) return false;
      while (j < line.size() && line[j] != ',') ++j;  // trailing blanks after the quote
      i = j;
    } else {
      const auto comma = line.find(',', i);
      const auto end = comma == std::string_view::npos ? line.size() : comma;
      cell = std::string(trim(line.substr(i, end - i)));
      i = end;
    }
    cells.push_back(cell);
    if (i >= line.size()) break;
    ++i;  // skip the comma
    if (i == line.size()) {
      cells.emplace_back();  // a trailing comma means one more, empty, cell
      break;
    }
  }
  return true;
}

bool parse_number(std::string_view text, double& value) {
  text = trim(text);
  if (text.empty()) return false;
  if (text.front() == '+') text.remove_prefix(1);
  const char* begin = text.data();
  const char* end = text.data() + text.size();
  const auto [ptr, ec] = std::from_chars(begin, end, value);
  if (ec == std::errc::result_out_of_range) {
    // from_chars leaves value unchanged on overflow/underflow; fall back to strtod's answer.
    value = std::strtod(std::string(text).c_str(), nullptr);
    return true;
  }
  return ec == std::errc() && ptr == end;
}

}  // namespace

void write_csv(const std::filesystem::path& path, const std::vector<std::string>& header,
               const std::vector<std::vector<double>>& rows, int significant_digits) {
  require(significant_digits >= 1 && significant_digits <= 17,
          "write_csv: significant_digits = {} for '{}' (expected 1..17)", significant_digits,
          path.string());
  for (std::size_t c = 0; c < header.size(); ++c)
    require(header[c].find_first_of("\r\n") == std::string::npos,
            "write_csv: column {} name '{}' of '{}' contains a line break (expected one line)", c,
            header[c], path.string());
  const std::size_t width = !header.empty() ? header.size() : (rows.empty() ? 0 : rows[0].size());
  for (std::size_t r = 0; r < rows.size(); ++r)
    require(rows[r].size() == width,
            "write_csv: row {} of '{}' has {} values (expected {}, the {})", r, path.string(),
            rows[r].size(), width, header.empty() ? "width of row 0" : "number of columns");

  write_file_atomically(path, [&](std::ostream& out) {
    if (!header.empty()) {
      for (std::size_t c = 0; c < header.size(); ++c) {
        if (c > 0) out << ',';
        out << quote_if_needed(header[c]);
      }
      out << '\n';
    }
    for (const auto& row : rows) {
      for (std::size_t c = 0; c < row.size(); ++c) {
        if (c > 0) out << ',';
        write_value(out, row[c], significant_digits);
      }
      out << '\n';
    }
  });
}

int CsvTable::column_index(std::string_view name) const {
  for (std::size_t c = 0; c < header.size(); ++c)
    if (header[c] == name) return static_cast<int>(c);
  return -1;
}

std::vector<double> CsvTable::column(std::string_view name) const {
  const int c = column_index(name);
  if (c < 0) {
    std::string available;
    for (const auto& h : header) available += (available.empty() ? "'" : ", '") + h + "'";
    fail("CsvTable::column: no column '{}' (available: {})", name,
         available.empty() ? "none" : available);
  }
  std::vector<double> values;
  values.reserve(rows.size());
  for (const auto& row : rows) values.push_back(row[static_cast<std::size_t>(c)]);
  return values;
}

CsvTable read_csv(const std::filesystem::path& path) {
  std::ifstream in(path);
  if (!in)
    fail<IoError>("read_csv: cannot open '{}' (check the path and permissions)", path.string());

  CsvTable table;
  std::string line;
  std::vector<std::string> cells;
  int line_number = 0;
  bool has_header = false;
  while (std::getline(in, line)) {
    ++line_number;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (trim(line).empty()) continue;
    if (!split_line(line, cells))
      fail("read_csv: '{}' line {}: unterminated quote", path.string(), line_number);
    if (!has_header) {
      table.header = cells;
      has_header = true;
      continue;
    }
    if (cells.size() != table.header.size())
      fail("read_csv: '{}' line {} has {} cells (expected {}, as in the header)", path.string(),
           line_number, cells.size(), table.header.size());
    std::vector<double> row(cells.size());
    for (std::size_t c = 0; c < cells.size(); ++c)
      if (!parse_number(cells[c], row[c]))
        fail("read_csv: '{}' line {} column {} ('{}'): '{}' is not a number", path.string(),
             line_number, c + 1, table.header[c], cells[c]);
    table.rows.push_back(std::move(row));
  }
  if (in.bad()) fail<IoError>("read_csv: reading '{}' failed", path.string());
  if (!has_header)
    fail("read_csv: '{}' is empty (expected a header line of column names)", path.string());
  return table;
}

}  // namespace socketsmith::report
