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

/// parse_frd's state between records: the section being read (nodes, elements or a result block),
/// the step, increment and total time the next block belongs to, and what was read so far.
class FrdParser {
 public:
  explicit FrdParser(const std::string& source) : source_(source) {}

  /// One record: @p line without its '\r', @p t the same trimmed. False at the end marker 9999.
  bool read(std::string_view line, std::string_view t, int line_no) {
    if (t.starts_with("-3")) {
      finish_block();
    } else if (t.starts_with("2C")) {
      mode_ = Mode::Nodes;
    } else if (t.starts_with("3C")) {
      mode_ = Mode::Elements;
    } else if (t.starts_with("1PSTEP")) {
      // "    1PSTEP   <set>   <increment>   <step>"
      std::istringstream in{std::string(t.substr(6))};
      int set = 0;
      in >> set >> increment_ >> step_;
    } else if (t.starts_with("100C")) {
      // "  100CL  101 2.50000E-01  ..." — the total time at columns 13..24 (2.0 at the end of a
      // second step of length 1).
      time_ = field<double>(line, 12, 12, source_, line_no);
    } else if (t.starts_with("-4")) {
      start_block(t);
    } else if (t.starts_with("-5")) {
      if (mode_ == Mode::Block) read_component(t);
    } else if (t.starts_with("-1")) {
      read_node_record(line, line_no);
    } else if (t.starts_with("-2")) {
      if (mode_ == Mode::Block) read_values(line, 13, cur_.values, source_, line_no);
    } else if (t.starts_with("9999")) {
      return false;
    }
    return true;
  }

  /// The results once every record is read: the open block closed, each block's values checked
  /// against its nodes × components. @throws InvalidInputError for a truncated block.
  FrdResults finish() {
    finish_block();
    for (const auto& b : res_.blocks)
      if (!b.components.empty() && b.values.size() != b.node_ids.size() * b.components.size())
        fail("read_frd: {}: block {} (step {}, increment {}) has {} values for {} nodes × {} components (truncated "
             "file?)",
             source_, b.name, b.step, b.increment, b.values.size(), b.node_ids.size(), b.components.size());
    return std::move(res_);
  }

 private:
  enum class Mode { None, Nodes, Elements, Block };

  void finish_block() {
    if (mode_ == Mode::Block) res_.blocks.push_back(std::move(cur_));
    cur_ = FrdBlock{};
    mode_ = Mode::None;
  }

  /// "-4  NAME ...": a result block of the current step, increment and time.
  void start_block(std::string_view t) {
    mode_ = Mode::Block;
    cur_ = FrdBlock{};
    std::istringstream in{std::string(t.substr(2))};
    in >> cur_.name;
    cur_.step = step_;
    cur_.increment = increment_;
    cur_.time = time_;
  }

  /// "-5  COMP ...": one component of the block's values.
  void read_component(std::string_view t) {
    std::istringstream in{std::string(t.substr(2))};
    std::string comp;
    in >> comp;
    // "ALL" marks a derived magnitude in DISP blocks: no column of its own.
    if (comp != "ALL") cur_.components.push_back(comp);
  }

  /// "-1 id values": a node's coordinates in the node section, its first values in a block.
  void read_node_record(std::string_view line, int line_no) {
    if (mode_ == Mode::Nodes) {
      res_.node_ids.push_back(field<int>(line, 3, 10, source_, line_no));
      row_.clear();
      read_values(line, 13, row_, source_, line_no);
      if (row_.size() < 3) fail("read_frd: {} line {}: a node record needs 3 coordinates", source_, line_no);
      res_.node_positions.emplace_back(row_[0], row_[1], row_[2]);
    } else if (mode_ == Mode::Block) {
      cur_.node_ids.push_back(field<int>(line, 3, 10, source_, line_no));
      read_values(line, 13, cur_.values, source_, line_no);
    }
  }

  const std::string& source_;
  FrdResults res_;
  Mode mode_ = Mode::None;
  FrdBlock cur_;
  int step_ = 0, increment_ = 0;
  double time_ = 0;
  std::vector<double> row_;  // a node record's coordinates
};

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
  FrdParser parser(source);
  int line_no = 0;
  size_t pos = 0;
  while (pos < text.size()) {
    size_t end = text.find('\n', pos);
    if (end == std::string_view::npos) end = text.size();
    std::string_view line = text.substr(pos, end - pos);
    pos = end + 1;
    ++line_no;
    if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
    const auto t = trim(line);
    if (t.empty()) continue;
    if (!parser.read(line, t, line_no)) break;
  }
  return parser.finish();
}

FrdResults read_frd(const std::filesystem::path& path) { return parse_frd(read_text_file(path), path.string()); }

}  // namespace socketsmith::calculix
