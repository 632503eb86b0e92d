#pragma once
/// @file fuzz_entry_points.h
/// What the fuzzers feed bytes to, shared by the libFuzzer targets (SOCKETSMITH_FUZZ, clang) and
/// the regression test of the normal suite (g++), which replays every file of tests/fuzz/corpus.
///
/// An entry point returns normally or throws one of the documented errors — InvalidInputError,
/// IoError, SolverError, TopologyError (exit codes 1–4) — each with a one-line message; those it
/// catches. Anything else escapes and is a finding: another exception type (exit 70), a message
/// on several lines (thrown as std::logic_error), a crash, a sanitizer report, a hang.

#include <cstddef>
#include <cstdint>
#include <string_view>
#include <vector>

namespace socketsmith::fuzz {

/// The targets: "stl", "obj", "ply" (the mesh readers and the mesh checks), "limb" (a limb file of
/// any of the four formats, told apart by its content, made into a limb model and meshed at 300
/// nodes, as `socketsmith mesh` does), "case_file" (the JSON
/// parser, the case validation and its round trip) and "design" (a case's patient, spots and brim
/// on a tiny generated stump: the design solve and a time-limited optimisation).
const std::vector<std::string_view>& targets();

/// Runs @p target on @p data. @throws what is a finding (see above).
void run(std::string_view target, const std::uint8_t* data, std::size_t size);

}  // namespace socketsmith::fuzz
