# Warnings and common flags live in one INTERFACE target that every socketsmith target links.
add_library(socketsmith_warnings INTERFACE)
target_compile_options(socketsmith_warnings INTERFACE
  -Wall -Wextra -Wpedantic -Wshadow -Wnon-virtual-dtor -Wcast-align -Wunused
  -Woverloaded-virtual -Wno-maybe-uninitialized)
if(SOCKETSMITH_NATIVE)
  target_compile_options(socketsmith_warnings INTERFACE -march=native)
endif()
# Internal invariants (SOCKETSMITH_ASSERT) stay active in Debug and in CI builds.
if(DEFINED ENV{CI})
  target_compile_definitions(socketsmith_warnings INTERFACE SOCKETSMITH_ENABLE_ASSERTS=1)
endif()
