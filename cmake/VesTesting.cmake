# ves_add_test(NAME name SOURCES a.cc b.cc LIBS ves::x ...)
# One GoogleTest executable, its cases discovered into CTest.
include(GoogleTest)
function(ves_add_test)
  cmake_parse_arguments(ARG "" "NAME;TIMEOUT" "SOURCES;LIBS;LABELS" ${ARGN})
  add_executable(${ARG_NAME} ${ARG_SOURCES})
  target_link_libraries(${ARG_NAME} PRIVATE ${ARG_LIBS} GTest::gtest GTest::gmock GTest::gtest_main)
  ves_target_defaults(${ARG_NAME})
  target_compile_definitions(${ARG_NAME} PRIVATE
    VES_SOURCE_DIR="${PROJECT_SOURCE_DIR}"
    VES_BINARY_DIR="${PROJECT_BINARY_DIR}")
  if(NOT ARG_TIMEOUT)
    set(ARG_TIMEOUT 300)
  endif()
  if(VES_SANITIZE OR VES_FUZZ)
    # Sanitized code runs several times slower.
    math(EXPR ARG_TIMEOUT "${ARG_TIMEOUT} * 3")
  endif()
  # Escape the list so several labels stay one LABELS value through
  # gtest_discover_tests' PROPERTIES key/value list.
  string(REPLACE ";" "\\;" labels "${ARG_LABELS}")
  gtest_discover_tests(${ARG_NAME}
    DISCOVERY_TIMEOUT 60
    PROPERTIES TIMEOUT ${ARG_TIMEOUT} LABELS "${labels}")
endfunction()
