#include "socketsmith/calculix/dat_reader.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdlib>

#include "socketsmith/core/errors.h"
#include "socketsmith/calculix/text_file.h"

namespace socketsmith::calculix {
namespace {

std::string lower(std::string_view s) {
  std::string out(s);
  std::transform(out.begin(), out.end(), out.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return out;
}

std::string_view trim(std::string_view s) {
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.front()))) s.remove_prefix(1);
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.back()))) s.remove_suffix(1);
  return s;
}

/// All numbers of a line when it consists of numbers only (true), else false. A node row in a
/// local system ends with "L" after its numbers: @p local (when given) is then set.
bool numbers_of(std::string_view line, std::vector<double>& out, bool* local = nullptr) {
  out.clear();
  std::string s(line);
  const char* p = s.c_str();
  while (*p) {
    while (*p && std::isspace(static_cast<unsigned char>(*p))) ++p;
    if (!*p) break;
    char* q = nullptr;
    const double v = std::strtod(p, &q);
    if (q == p) {
      if (local && !out.empty() && (*p == 'L' || *p == 'l') && trim(std::string_view(p + 1)).empty()) {
        *local = true;
        return true;
      }
      return false;
    }
    out.push_back(v);
    p = q;
  }
  return !out.empty();
}

}  // namespace

std::vector<DatBlock> parse_dat(std::string_view text, const std::string& source) {
  std::vector<DatBlock> blocks;
  size_t pos = 0;
  int line_no = 0;
  std::vector<double> nums;
  bool in_block = false;
  while (pos < text.size()) {
    size_t end = text.find('\n', pos);
    if (end == std::string_view::npos) end = text.size();
    const std::string_view line = trim(text.substr(pos, end - pos));
    pos = end + 1;
    ++line_no;
    if (line.empty()) continue;
    const std::string l = lower(line);
    const auto at_time = l.rfind(" and time");
    const auto for_set = l.find(" for set ");
    const auto slave = l.find("statistics for slave set ");
    if (at_time != std::string::npos && (for_set != std::string::npos || slave != std::string::npos)) {
      DatBlock b;
      if (slave == 0) {
        b.title = "statistics";
        const auto start = std::string_view("statistics for slave set ").size();
        const auto comma = l.find(',', start);
        b.set = std::string(line.substr(start, (comma == std::string::npos ? at_time : comma) - start));
      } else {
        b.title = std::string(trim(line.substr(0, for_set)));
        b.set = std::string(trim(line.substr(for_set + 9, at_time - for_set - 9)));
      }
      if (!numbers_of(line.substr(at_time + 9), nums) || nums.size() != 1)
        fail("read_dat: {} line {}: cannot read the time in '{}'", source, line_no, std::string(line));
      b.time = nums[0];
      blocks.push_back(std::move(b));
      in_block = true;
      continue;
    }
    if (!in_block) continue;
    if (numbers_of(line, nums, &blocks.back().local)) blocks.back().rows.push_back(nums);
    // Sub-headers of the contact statistics ("total surface force ...") are skipped.
  }
  return blocks;
}

std::vector<DatBlock> read_dat(const std::filesystem::path& path) { return parse_dat(read_text_file(path), path.string()); }

const DatBlock* last_block(const std::vector<DatBlock>& blocks, std::string_view title_prefix, std::string_view set) {
  const std::string t = lower(title_prefix), s = lower(set);
  for (auto it = blocks.rbegin(); it != blocks.rend(); ++it)
    if (lower(it->title).starts_with(t) && lower(it->set) == s) return &*it;
  return nullptr;
}

const DatBlock* block_at(const std::vector<DatBlock>& blocks, std::string_view title_prefix, std::string_view set,
                         double time) {
  const std::string t = lower(title_prefix), s = lower(set);
  for (auto it = blocks.rbegin(); it != blocks.rend(); ++it)
    if (std::abs(it->time - time) <= 1e-9 && lower(it->title).starts_with(t) && lower(it->set) == s) return &*it;
  return nullptr;
}

}  // namespace socketsmith::calculix
