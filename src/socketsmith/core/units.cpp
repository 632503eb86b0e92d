#include "socketsmith/core/units.h"

#include <algorithm>
#include <cctype>

#include "socketsmith/core/errors.h"

namespace socketsmith::units {

LengthUnit parse_length_unit(std::string_view text) {
  std::string t(text);
  std::transform(t.begin(), t.end(), t.begin(), [](unsigned char c) { return std::tolower(c); });
  if (t == "m") return LengthUnit::Metre;
  if (t == "mm") return LengthUnit::Millimetre;
  fail("parse_length_unit: unknown length unit '{}' (expected 'mm' or 'm')", text);
}

std::string to_string(LengthUnit unit) { return unit == LengthUnit::Metre ? "m" : "mm"; }

}  // namespace socketsmith::units
