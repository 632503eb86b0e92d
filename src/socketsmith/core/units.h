#pragma once
/// @file units.h
/// SI units inside every library. Scans arrive in millimetres: convert at the IO boundary.

#include <string>
#include <string_view>

namespace socketsmith::units {

inline constexpr double m = 1.0;      ///< metre (the internal unit of length)
inline constexpr double mm = 1e-3;    ///< millimetre in metres
inline constexpr double cm = 1e-2;    ///< centimetre in metres
inline constexpr double Pa = 1.0;     ///< pascal (internal unit of pressure)
inline constexpr double kPa = 1e3;    ///< kilopascal in pascals
inline constexpr double N = 1.0;      ///< newton
inline constexpr double kg = 1.0;     ///< kilogram
inline constexpr double s = 1.0;      ///< second
inline constexpr double ms = 1e-3;    ///< millisecond in seconds
inline constexpr double deg = 0.017453292519943295;  ///< degree in radians
inline constexpr double kGravity = 9.80665;          ///< standard gravity [m/s^2]

/// Length unit of a file on disk.
enum class LengthUnit { Metre, Millimetre };

/// Scale factor that converts a length in @p unit to metres.
constexpr double to_metres(LengthUnit unit) { return unit == LengthUnit::Metre ? 1.0 : mm; }

/// Parses "m" / "mm" (case-insensitive). @throws InvalidInputError for anything else.
LengthUnit parse_length_unit(std::string_view text);

/// "m" or "mm".
std::string to_string(LengthUnit unit);

}  // namespace socketsmith::units
