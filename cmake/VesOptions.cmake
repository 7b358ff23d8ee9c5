# Shared build options: warnings for our own code, sanitizers, ccache.
option(VES_BUILD_TESTS "Build the GoogleTest suites" ON)
option(VES_BUILD_BENCH "Build the benchmarks in bench/" ON)
option(VES_WITH_POSTGRES "Build the PostgreSQL Store (libpqxx)" OFF)
set(VES_SANITIZE "" CACHE STRING "Sanitizer: address, undefined, thread or empty")
set_property(CACHE VES_SANITIZE PROPERTY STRINGS "" address undefined thread)

find_program(VES_CCACHE ccache)
if(VES_CCACHE AND NOT CMAKE_CXX_COMPILER_LAUNCHER)
  set(CMAKE_CXX_COMPILER_LAUNCHER "${VES_CCACHE}")
  set(CMAKE_C_COMPILER_LAUNCHER "${VES_CCACHE}")
endif()

if(VES_SANITIZE)
  if(NOT VES_SANITIZE MATCHES "^(address|undefined|thread)$")
    message(FATAL_ERROR "VES_SANITIZE must be address, undefined or thread, not '${VES_SANITIZE}'")
  endif()
  add_compile_options(-fsanitize=${VES_SANITIZE} -fno-omit-frame-pointer)
  add_link_options(-fsanitize=${VES_SANITIZE})
  if(VES_SANITIZE STREQUAL "undefined")
    # A finding fails the test instead of scrolling past in its log.
    add_compile_options(-fno-sanitize-recover=undefined)
  endif()
  if(CMAKE_CXX_COMPILER_ID STREQUAL "GNU")
    # GCC 12 reports false -Wmaybe-uninitialized inside libstdc++ (std::regex,
    # std::function) once sanitizers instrument it; still shown, not fatal.
    add_compile_options(-Wno-error=maybe-uninitialized)
    if(VES_SANITIZE STREQUAL "thread")
      # Boost.Asio's scheduler uses std::atomic_thread_fence, which TSan does
      # not model (GCC's -Wtsan); VES's own code has no fences (seqlock.h).
      add_compile_options(-Wno-error=tsan)
    endif()
  endif()
endif()

# libFuzzer targets in tests/fuzz (docs/fuzzing.md): clang only. Everything is
# built with coverage for the fuzzer and with ASan + UBSan, so the same build
# also runs the sanitized test suites.
option(VES_FUZZ "Build the libFuzzer targets (clang) with ASan and UBSan" OFF)
if(VES_FUZZ)
  if(NOT CMAKE_CXX_COMPILER_ID STREQUAL "Clang")
    message(FATAL_ERROR "VES_FUZZ needs clang (CXX=clang++-14), not ${CMAKE_CXX_COMPILER_ID}")
  endif()
  if(VES_SANITIZE)
    message(FATAL_ERROR "VES_FUZZ brings its own sanitizers (address, undefined): drop VES_SANITIZE")
  endif()
  add_compile_options(-fsanitize=fuzzer-no-link,address,undefined -fno-sanitize-recover=undefined
                      -fno-omit-frame-pointer)
  add_link_options(-fsanitize=address,undefined)
endif()

# Interface target carrying the warning flags; every ves_* target links it.
# Generated code (protobuf) does not, so -Werror stays on our code only.
add_library(ves_warnings INTERFACE)
target_compile_options(ves_warnings INTERFACE -Wall -Wextra -Werror)

# ves_target_defaults(<target>): the warning flags.
function(ves_target_defaults target)
  target_link_libraries(${target} PRIVATE ves_warnings)
endfunction()

# ves_library(<name> [PUBLIC <item>...] [PRIVATE <item>...]): completes the
# static library ves_<name>, declared just before with add_library(ves_<name>
# STATIC <sources>): its alias ves::<name>, the repository root on its and its
# users' include path, its links, and ves_target_defaults.
function(ves_library name)
  cmake_parse_arguments(PARSE_ARGV 1 ARG "" "" "PUBLIC;PRIVATE")
  if(ARG_UNPARSED_ARGUMENTS)
    message(FATAL_ERROR "ves_library(${name}): unexpected ${ARG_UNPARSED_ARGUMENTS}")
  endif()
  set(target ves_${name})
  add_library(ves::${name} ALIAS ${target})
  target_include_directories(${target} PUBLIC ${PROJECT_SOURCE_DIR})
  if(ARG_PUBLIC)
    target_link_libraries(${target} PUBLIC ${ARG_PUBLIC})
  endif()
  if(ARG_PRIVATE)
    target_link_libraries(${target} PRIVATE ${ARG_PRIVATE})
  endif()
  ves_target_defaults(${target})
endfunction()
