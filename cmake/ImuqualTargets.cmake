# One helper per kind of target. Every target gets the same warnings and
# standard; tests are registered with CTest one line each.

set(IMUQUAL_WARNINGS -Wall -Wextra -Wpedantic)

# imuqual_library(NAME SOURCES ... DEPS ...)
function(imuqual_library name)
  cmake_parse_arguments(ARG "" "" "SOURCES;DEPS" ${ARGN})
  add_library(${name} STATIC ${ARG_SOURCES})
  target_include_directories(${name} PUBLIC ${PROJECT_SOURCE_DIR})
  target_compile_options(${name} PRIVATE ${IMUQUAL_WARNINGS})
  target_link_libraries(${name} PUBLIC ${ARG_DEPS})
endfunction()

# imuqual_executable(NAME SOURCES ... DEPS ...): lands in build/bin/.
function(imuqual_executable name)
  cmake_parse_arguments(ARG "" "" "SOURCES;DEPS" ${ARGN})
  add_executable(${name} ${ARG_SOURCES})
  target_compile_options(${name} PRIVATE ${IMUQUAL_WARNINGS})
  target_link_libraries(${name} PRIVATE ${ARG_DEPS})
endfunction()

# imuqual_test(NAME SOURCES ... DEPS ... [LABELS ...] [TIMEOUT s] [NETNS]
#              [SANITIZER_SKIP Suite.Case ...])
# NETNS: run in a private network namespace (tests/netns_run) when possible.
# SANITIZER_SKIP: cases left out of the ASan + UBSan build (IMUQUAL_SANITIZE)
# only: Monte Carlo rates and long-run arithmetic that run the code of a
# sibling case many times over. The Release pass asserts them; the memory
# checks see their code in the sibling.
function(imuqual_test name)
  cmake_parse_arguments(ARG "NETNS" "TIMEOUT" "SOURCES;DEPS;LABELS;SANITIZER_SKIP" ${ARGN})
  add_executable(${name} ${ARG_SOURCES})
  set_target_properties(${name} PROPERTIES RUNTIME_OUTPUT_DIRECTORY ${CMAKE_BINARY_DIR}/tests)
  target_compile_options(${name} PRIVATE ${IMUQUAL_WARNINGS})
  # The test's own file at a lower level than the code under test: test files
  # were 40 % of the Release build's CPU, and GCC compiles them at -O1 in 60 %
  # of -O3's time; Clang with the sanitizers at -O0 in 40-50 % of -O1's (the
  # maths' own tests run a few seconds longer for it). Their arithmetic is
  # IEEE at any level (no fast-math).
  if(IMUQUAL_SANITIZE)
    target_compile_options(${name} PRIVATE -O0)
  elseif(CMAKE_BUILD_TYPE STREQUAL "Release")
    target_compile_options(${name} PRIVATE -O1)
  endif()
  target_compile_definitions(${name} PRIVATE
    IMUQUAL_SOURCE_DIR="${PROJECT_SOURCE_DIR}"
    IMUQUAL_BIN_DIR="${CMAKE_BINARY_DIR}/bin")
  target_link_libraries(${name} PRIVATE ${ARG_DEPS} GTest::gtest GTest::gtest_main)
  if(ARG_NETNS)
    add_test(NAME ${name} COMMAND ${PROJECT_SOURCE_DIR}/tests/netns_run $<TARGET_FILE:${name}>)
  else()
    add_test(NAME ${name} COMMAND ${name})
  endif()
  if(NOT ARG_TIMEOUT)
    set(ARG_TIMEOUT 300)
  endif()
  set_tests_properties(${name} PROPERTIES TIMEOUT ${ARG_TIMEOUT} LABELS "${ARG_LABELS}")
  if(IMUQUAL_SANITIZE AND ("long" IN_LIST ARG_LABELS OR "statistical" IN_LIST ARG_LABELS))
    # The sanitizer pass leaves `long` and `statistical` tests out
    # (scripts/test): not built there.
    set_target_properties(${name} PROPERTIES EXCLUDE_FROM_ALL TRUE)
  endif()
  if(IMUQUAL_SANITIZE AND ARG_SANITIZER_SKIP)
    list(JOIN ARG_SANITIZER_SKIP ":" skipped)
    set_tests_properties(${name} PROPERTIES ENVIRONMENT "GTEST_FILTER=-${skipped}")
  endif()
endfunction()

# imuqual_fuzzer(NAME SOURCES ... DEPS ...): a libFuzzer binary in fuzz/ of
# the sanitizer build (Clang, -DIMUQUAL_SANITIZE=ON; tests/fuzz).
function(imuqual_fuzzer name)
  cmake_parse_arguments(ARG "" "" "SOURCES;DEPS" ${ARGN})
  add_executable(${name} ${ARG_SOURCES})
  set_target_properties(${name} PROPERTIES RUNTIME_OUTPUT_DIRECTORY ${CMAKE_BINARY_DIR}/fuzz)
  target_compile_options(${name} PRIVATE ${IMUQUAL_WARNINGS} -fsanitize=fuzzer-no-link)
  target_link_options(${name} PRIVATE -fsanitize=fuzzer)
  target_link_libraries(${name} PRIVATE ${ARG_DEPS})
endfunction()

# imuqual_benchmark(NAME SOURCES ... DEPS ...): Google Benchmark binary in build/bench/.
function(imuqual_benchmark name)
  cmake_parse_arguments(ARG "" "" "SOURCES;DEPS" ${ARGN})
  if(NOT TARGET benchmark::benchmark OR NOT IMUQUAL_BENCHMARKS)
    return()
  endif()
  add_executable(${name} ${ARG_SOURCES})
  set_target_properties(${name} PROPERTIES RUNTIME_OUTPUT_DIRECTORY ${CMAKE_BINARY_DIR}/bench)
  target_compile_options(${name} PRIVATE ${IMUQUAL_WARNINGS})
  target_link_libraries(${name} PRIVATE ${ARG_DEPS} benchmark::benchmark)
endfunction()
