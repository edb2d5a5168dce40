# The plain-CMake build: CMakeLists.txt includes this when catkin is not found, and then builds
# the ROS-free part of fem_cloth from the same source and test lists as the catkin build:
#   fem_cloth_core       Eigen 3.3 (OpenMP and CHOLMOD when found, as with catkin)
#   fem_cloth_rendering  the core only (libpng is for fem_cloth_render, a ROS program)
#   fem_cloth_io         yaml-cpp
#   fem_cloth_validate_lib  the core only
#   fem_cloth_materials, fem_cloth_validate  CLI11 and nlohmann_json
#   the core tests       googletest (Debian: googletest or libgtest-dev), run with ctest
# and prints one STATUS line naming what it builds and what it leaves out, and why.
#
# The build folder is laid out like a catkin devel space (programs in lib/fem_cloth/, a .catkin
# marker naming the source folder), so the programs find their data the same way
# (include/fem_cloth/core/package_paths.h). The install destinations are catkin's.

set(CATKIN_PACKAGE_LIB_DESTINATION lib)
set(CATKIN_PACKAGE_BIN_DESTINATION lib/${PROJECT_NAME})
set(CATKIN_PACKAGE_INCLUDE_DESTINATION include/${PROJECT_NAME})
set(CATKIN_PACKAGE_SHARE_DESTINATION share/${PROJECT_NAME})
set(CMAKE_RUNTIME_OUTPUT_DIRECTORY ${CMAKE_BINARY_DIR}/${CATKIN_PACKAGE_BIN_DESTINATION})
file(WRITE ${CMAKE_BINARY_DIR}/.catkin "${PROJECT_SOURCE_DIR}")

option(BUILD_TESTING "Build the core tests (ctest runs them)" ON)
set(FEM_CLOTH_TESTING OFF)
if(BUILD_TESTING)
  find_package(GTest QUIET)
  if(GTest_FOUND)
    enable_testing()
    set(FEM_CLOTH_TESTING ON)
  endif()
endif()

# fem_cloth_core_test without catkin: the same gtest program, registered with ctest.
function(fem_cloth_plain_gtest name)
  add_executable(${name} ${ARGN})
  target_link_libraries(${name} fem_cloth_core GTest::gtest_main)
  add_test(NAME ${name} COMMAND ${name})
endfunction()

# The STATUS line: what this build has and what it leaves out (called after all targets).
function(fem_cloth_plain_summary)
  set(built)
  foreach(target fem_cloth_core fem_cloth_rendering fem_cloth_io fem_cloth_validate_lib
      fem_cloth_materials fem_cloth_validate fem_cloth_bench)
    if(TARGET ${target})
      list(APPEND built ${target})
    endif()
  endforeach()
  string(CONCAT left "the ROS part (catkin not found: fem_cloth_ros, fem_cloth_report_lib, "
    "the node, fem_cloth_sim, fem_cloth_render, fem_cloth_report, the ROS tests and rostests)")
  if(NOT TARGET fem_cloth_io)
    list(APPEND left "fem_cloth_io and the tests on scenes (yaml-cpp not found)")
  endif()
  if(NOT TARGET fem_cloth_materials)
    list(APPEND left "fem_cloth_materials, fem_cloth_validate and their tests (CLI11 or nlohmann_json not found)")
  endif()
  if(NOT TARGET fem_cloth_bench)
    list(APPEND left "fem_cloth_bench (Google Benchmark or yaml-cpp not found)")
  endif()
  if(FEM_CLOTH_TESTING)
    get_property(tests DIRECTORY ${PROJECT_SOURCE_DIR} PROPERTY TESTS)
    list(LENGTH tests count)
    set(tests_text " and ${count} core tests (ctest)")
  elseif(BUILD_TESTING)
    list(APPEND left "the tests (googletest not found: apt-get install googletest)")
  else()
    list(APPEND left "the tests (BUILD_TESTING is OFF)")
  endif()
  string(REPLACE ";" ", " built "${built}")
  string(REPLACE ";" "; " left "${left}")
  message(STATUS "fem_cloth (plain CMake, without catkin): building ${built}${tests_text}; "
    "left out: ${left}")
endfunction()
