// libFuzzer target (SOCKETSMITH_FUZZ=ON, clang): one per entry point of fuzz_entry_points.h,
// chosen by SOCKETSMITH_FUZZ_TARGET. Run by scripts/fuzz.sh.
#include <cstddef>
#include <cstdint>

#include "fuzz_entry_points.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  socketsmith::fuzz::run(SOCKETSMITH_FUZZ_TARGET, data, size);
  return 0;
}
