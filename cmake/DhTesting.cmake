# Unit tests live beside the code they test (<service>/test/), one GoogleTest executable per test folder;
# integration and system tests live in tests/. Included from the top CMakeLists.txt when DH_BUILD_TESTS.
include(GoogleTest)

# Tests find configs through DH_HOME, set to this checkout.
set(DH_TEST_ENV "DH_HOME=${PROJECT_SOURCE_DIR}")

# dh_unit_test(name src... LINK lib...): an in-process test executable, ctest label `unit`.
function(dh_unit_test name)
  cmake_parse_arguments(PARSE_ARGV 1 arg "" "" "LINK")
  add_executable(${name} ${arg_UNPARSED_ARGUMENTS})
  target_link_libraries(${name} PRIVATE GTest::gtest_main ${arg_LINK})
  target_include_directories(${name} PRIVATE ${PROJECT_SOURCE_DIR}/tests/support)  # helpers shared by tests
  gtest_discover_tests(${name} PROPERTIES LABELS unit ENVIRONMENT "${DH_TEST_ENV}" DISCOVERY_TIMEOUT 30)
endfunction()
