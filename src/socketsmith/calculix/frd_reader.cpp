#include "socketsmith/calculix/frd_reader.h"

#include <algorithm>
#include <charconv>
#include <fstream>
#include <sstream>

#include <fmt/format.h>

#include "socketsmith/core/errors.h"
#include "socketsmith/calculix/text_file.h"

namespace socketsmith::calculix {
namespace {

std::string_view trim(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\r' || s.front() == '\t')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\r' || s.back() == '\t')) s.remove_suffix(1);
  return s;
}

/// The number in columns [pos, pos + width) of a fixed-width record.
template <class T>
T field(std::string_view line, size_t pos, size_t width, const std::string& source, int line_no) {
  if (pos >= line.size()) fail("read_frd: {} line {}: record too short (expected a field at column {})", source, line_no, pos + 1);
  const auto f = trim(line.substr(pos, width));
  T v{};
  const auto [p, ec] = std::from_chars(f.data(), f.data() + f.size(), v);
  if (ec != std::errc() || p != f.data() + f.size())
    fail("read_frd: {} line {}: '{}' is not a number", source, line_no, std::string(f));
  return v;
}

/// Values of a " -1"/" -2" record after the node id (12 columns each).
void read_values(std::string_view line, size_t start, std::vector<double>& out, const std::string& source, int line_no) {
  for (size_t pos = start; pos + 1 < line.size(); pos += 12) {
    if (trim(line.substr(pos, 12)).empty()) break;
    out.push_back(field<double>(line, pos, 12, source, line_no));
  }
}

}  // namespace

int FrdBlock::component_index(std::string_view component) const {
  for (size_t k = 0; k < components.size(); ++k)
    if (components[k] == component) return static_cast<int>(k);
  return -1;
}

std::vector<double> FrdBlock::dense(std::string_view component, int num_nodes) const {
  const int c = component_index(component);
  if (c < 0) {
    std::string have;
    for (const auto& n : components) have += (have.empty() ? "" : ", ") + n;
    fail("FrdBlock: block {} has no component {} (it has {})", name, std::string(component), have);
  }
  const size_t nc = components.size();
  std::vector<double> out(static_cast<size_t>(std::max(num_nodes, 0)), 0.0);
  for (size_t r = 0; r < node_ids.size(); ++r)
    if (node_ids[r] >= 1 && node_ids[r] <= num_nodes) out[node_ids[r] - 1] = values[r * nc + c];
  return out;
}

const FrdBlock* FrdResults::last(std::string_view name, int step) const {
  for (auto it = blocks.rbegin(); it != blocks.rend(); ++it)
    if (it->name == name && (step <= 0 || it->step == step)) return &*it;
  return nullptr;
}

FrdResults parse_frd(std::string_view text, const std::string& source) {
  FrdResults res;
  enum class Mode { None, Nodes, Elements, Block } mode = Mode::None;
  FrdBlock cur;
  int step = 0, increment = 0;
  double time = 0;
  int line_no = 0;
  size_t pos = 0;
  std::vector<double> row;
  const auto finish_block = [&] {
    if (mode == Mode::Block) res.blocks.push_back(std::move(cur));
    cur = FrdBlock{};
    mode = Mode::None;
  };
  while (pos < text.size()) {
    size_t end = text.find('\n', pos);
    if (end == std::string_view::npos) end = text.size();
    std::string_view line = text.substr(pos, end - pos);
    pos = end + 1;
    ++line_no;
    if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
    const auto t = trim(line);
    if (t.empty()) continue;
    if (t.starts_with("-3")) {
      finish_block();
      continue;
    }
    if (t.starts_with("2C")) {
      mode = Mode::Nodes;
      continue;
    }
    if (t.starts_with("3C")) {
      mode = Mode::Elements;
      continue;
    }
    if (t.starts_with("1PSTEP")) {
      // "    1PSTEP   <set>   <increment>   <step>"
      std::istringstream in{std::string(t.substr(6))};
      int set = 0;
      in >> set >> increment >> step;
      continue;
    }
    if (t.starts_with("100C")) {
      // "  100CL  101 2.50000E-01  ..." — the total time at columns 13..24 (2.0 at the end of a
      // second step of length 1).
      time = field<double>(line, 12, 12, source, line_no);
      continue;
    }
    if (t.starts_with("-4")) {
      mode = Mode::Block;
      cur = FrdBlock{};
      std::istringstream in{std::string(t.substr(2))};
      in >> cur.name;
      cur.step = step;
      cur.increment = increment;
      cur.time = time;
      continue;
    }
    if (t.starts_with("-5")) {
      if (mode == Mode::Block) {
        std::istringstream in{std::string(t.substr(2))};
        std::string comp;
        in >> comp;
        // "ALL" marks a derived magnitude in DISP blocks: no column of its own.
        if (comp != "ALL") cur.components.push_back(comp);
      }
      continue;
    }
    if (t.starts_with("-1")) {
      if (mode == Mode::Nodes) {
        res.node_ids.push_back(field<int>(line, 3, 10, source, line_no));
        row.clear();
        read_values(line, 13, row, source, line_no);
        if (row.size() < 3) fail("read_frd: {} line {}: a node record needs 3 coordinates", source, line_no);
        res.node_positions.emplace_back(row[0], row[1], row[2]);
      } else if (mode == Mode::Block) {
        cur.node_ids.push_back(field<int>(line, 3, 10, source, line_no));
        read_values(line, 13, cur.values, source, line_no);
      }
      continue;
    }
    if (t.starts_with("-2")) {
      if (mode == Mode::Block) read_values(line, 13, cur.values, source, line_no);
      continue;
    }
    if (t.starts_with("9999")) break;
  }
  finish_block();
  for (const auto& b : res.blocks)
    if (!b.components.empty() && b.values.size() != b.node_ids.size() * b.components.size())
      fail("read_frd: {}: block {} (step {}, increment {}) has {} values for {} nodes × {} components (truncated file?)",
           source, b.name, b.step, b.increment, b.values.size(), b.node_ids.size(), b.components.size());
  return res;
}

FrdResults read_frd(const std::filesystem::path& path) { return parse_frd(read_text_file(path), path.string()); }

}  // namespace socketsmith::calculix
