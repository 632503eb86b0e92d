#pragma once
/// @file enum_names.h
/// An enum's names as one table, read both ways: `to_string` and `parse_*` of an option (a tissue
/// model, a check mode, a log level) are one line each over the table instead of a switch and a
/// chain of comparisons that must be kept in step.
///
///     constexpr EnumName<DampingLaw> kDampingLaws[] = {{DampingLaw::ThesisEq3, "thesis-eq3"},
///                                                      {DampingLaw::Critical, "critical"}};
///     std::string to_string(DampingLaw law) { return name_of(kDampingLaws, law); }

#include <cstddef>
#include <optional>
#include <string>
#include <string_view>

#include <fmt/format.h>

#include "socketsmith/core/errors.h"

namespace socketsmith {

/// One value of an enum and its name as the user writes it.
template <class E>
struct EnumName {
  E value;
  std::string_view name;
};

/// The name of @p value in @p names; @p fallback for a value the table does not list.
template <class E, std::size_t N>
std::string name_of(const EnumName<E> (&names)[N], E value, std::string_view fallback = "?") {
  for (const auto& n : names)
    if (n.value == value) return std::string(n.name);
  return std::string(fallback);
}

/// The value named exactly @p text in @p names, or nothing.
template <class E, std::size_t N>
std::optional<E> find_named(const EnumName<E> (&names)[N], std::string_view text) {
  for (const auto& n : names)
    if (n.name == text) return n.value;
  return std::nullopt;
}

/// The value named exactly @p text in @p names.
/// @throws InvalidInputError with @p message, whose one `{}` shows @p text, when none is.
template <class E, std::size_t N>
E parse_named(const EnumName<E> (&names)[N], std::string_view text, fmt::format_string<std::string_view> message) {
  if (const auto value = find_named(names, text)) return *value;
  throw InvalidInputError(detail::one_line_message(fmt::format(message, std::string_view(text))));
}

}  // namespace socketsmith
