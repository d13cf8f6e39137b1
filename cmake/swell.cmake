# Helpers shared by every part of the tree.

# swell_catch_test(NAME LABEL label [LABEL ...] SOURCES src... [LIBS lib...])
# One Catch2 executable; every TEST_CASE becomes its own ctest test carrying the labels.
function(swell_catch_test name)
  cmake_parse_arguments(T "" "" "LABEL;SOURCES;LIBS" ${ARGN})
  add_executable(${name} ${T_SOURCES})
  if(NOT SWELL_TEST_PROGRAMS) # a tree for the programs only (tools/test's Release tree)
    set_target_properties(${name} PROPERTIES EXCLUDE_FROM_ALL ON)
  endif()
  target_link_libraries(${name} PRIVATE ${T_LIBS} Catch2::Catch2WithMain)
  # tests/support: the helpers the tests share (running a program, bad-argument tables, UDP ports)
  target_include_directories(${name} PRIVATE ${PROJECT_SOURCE_DIR}/tests/support)
  set_target_properties(${name} PROPERTIES RUNTIME_OUTPUT_DIRECTORY ${CMAKE_BINARY_DIR}/tests)
  # --warn NoTests: a ctest test whose name no longer selects its TEST_CASE fails instead of passing
  # empty (discovery splits names at ';', so such a name would run nothing)
  catch_discover_tests(${name} TEST_PREFIX "${name}: " EXTRA_ARGS --warn NoTests
    PROPERTIES LABELS "${T_LABEL}")
endfunction()

# Add every immediate subdirectory of the current source dir that has a CMakeLists.txt, in name
# order, so that parts can be added side by side without editing a shared list.
function(swell_add_subdirs)
  file(GLOB entries LIST_DIRECTORIES true RELATIVE ${CMAKE_CURRENT_SOURCE_DIR} ${CMAKE_CURRENT_SOURCE_DIR}/*)
  list(SORT entries)
  foreach(d ${entries})
    if(IS_DIRECTORY ${CMAKE_CURRENT_SOURCE_DIR}/${d} AND EXISTS ${CMAKE_CURRENT_SOURCE_DIR}/${d}/CMakeLists.txt)
      add_subdirectory(${d})
    endif()
  endforeach()
endfunction()
