# Helpers shared by every folder: warnings and sanitizers on our own targets
# only, one call to declare a layer library, one call to declare a test.

function(furn_target_defaults target)
  target_compile_options(${target} PRIVATE -Wall -Wextra -Wno-unknown-pragmas)
  if(FURN_WERROR)
    target_compile_options(${target} PRIVATE -Werror)
  endif()
  if(NOT FURN_SANITIZE STREQUAL "")
    # No recovery: a UBSan finding ends the process, so the test that met it fails.
    target_compile_options(${target} PRIVATE
      -fsanitize=${FURN_SANITIZE} -fno-sanitize-recover=all -fno-omit-frame-pointer)
    target_link_options(${target} PRIVATE -fsanitize=${FURN_SANITIZE})
  endif()
endfunction()

# furn_add_library(NAME furn_core SOURCES a.cc b.cc PUBLIC_LINKS ... PRIVATE_LINKS ...)
function(furn_add_library)
  cmake_parse_arguments(ARG "" "NAME" "SOURCES;PUBLIC_LINKS;PRIVATE_LINKS" ${ARGN})
  add_library(${ARG_NAME} STATIC ${ARG_SOURCES})
  target_include_directories(${ARG_NAME} PUBLIC ${PROJECT_SOURCE_DIR})
  target_link_libraries(${ARG_NAME} PUBLIC ${ARG_PUBLIC_LINKS} PRIVATE ${ARG_PRIVATE_LINKS})
  furn_target_defaults(${ARG_NAME})
  if(NOT FURN_SANITIZE STREQUAL "")
    target_link_options(${ARG_NAME} INTERFACE -fsanitize=${FURN_SANITIZE})
  endif()
endfunction()

# furn_add_test(FOLDER core NAME sgf SOURCES sgf_test.cc LINKS furn_core [LABELS slow] [WHOLE]
#               [EMBREE_ISAS avx2 sse4.2] [TORCH_ISAS avx2] [ISA_FILTER gtest-filter])
# builds tests/<folder>/<name>_test and registers each TEST as "<folder>/<name>.<Suite>.<Case>";
# WHOLE registers the binary as one test instead (for suites with a costly shared setup).
# EMBREE_ISAS registers every test once more per listed ISA, as "<folder>/<name>[isa].<...>",
# run with FURN_EMBREE_CONFIG=isa=<isa>: Embree's kernels for CPUs other than this one
# (skipped where the CPU lacks the ISA). TORCH_ISAS does the same for libtorch and oneDNN,
# as "<folder>/<name>[torch-isa].<...>" with FURN_TORCH_ISA=<isa> (tests/test_main.cc sets
# ATEN_CPU_CAPABILITY and DNNL_MAX_CPU_ISA from it): an AVX-512 machine runs the AVX2 kernels
# too. ISA_FILTER (a gtest filter) limits those repetitions to the tests it names: an
# end-to-end suite repeats one representative run, not every case (the suite's time).
function(furn_add_test)
  cmake_parse_arguments(ARG "WHOLE" "FOLDER;NAME;TIMEOUT;ISA_FILTER;PRECISION_FILTER" "SOURCES;LINKS;LABELS;EMBREE_ISAS;TORCH_ISAS;PRECISIONS" ${ARGN})
  set(target ${ARG_FOLDER}_${ARG_NAME}_test)
  add_executable(${target} ${ARG_SOURCES})
  target_link_libraries(${target} PRIVATE ${ARG_LINKS} furn_test_main GTest::gtest GTest::gmock)
  target_compile_definitions(${target} PRIVATE
    FURN_TEST_BINARY_DIR="${CMAKE_CURRENT_BINARY_DIR}"
    FURN_SOURCE_DIR="${PROJECT_SOURCE_DIR}")
  furn_target_defaults(${target})
  if(NOT ARG_LABELS)
    set(ARG_LABELS fast)
  endif()
  if(NOT ARG_TIMEOUT)
    set(ARG_TIMEOUT 300)
  endif()
  if(NOT FURN_SANITIZE STREQUAL "")
    # ASan and UBSan make training and evaluation 3 to 5 times slower.
    math(EXPR ARG_TIMEOUT "${ARG_TIMEOUT} * 5")
  endif()
  if(ARG_WHOLE)
    add_test(NAME "${ARG_FOLDER}/${ARG_NAME}" COMMAND ${target})
    set_tests_properties("${ARG_FOLDER}/${ARG_NAME}" PROPERTIES
      LABELS "${ARG_LABELS}" TIMEOUT ${ARG_TIMEOUT})
    return()
  endif()
  gtest_discover_tests(${target}
    TEST_PREFIX "${ARG_FOLDER}/${ARG_NAME}."
    PROPERTIES LABELS "${ARG_LABELS}" TIMEOUT ${ARG_TIMEOUT}
    DISCOVERY_TIMEOUT 60)
  if(NOT ARG_ISA_FILTER)
    set(ARG_ISA_FILTER "*")
  endif()
  foreach(isa IN LISTS ARG_EMBREE_ISAS)
    # One value per property: gtest_discover_tests splits lists. Select these
    # tests with ctest -R '\[avx2\]'.
    gtest_discover_tests(${target}
      TEST_PREFIX "${ARG_FOLDER}/${ARG_NAME}[${isa}]."
      PROPERTIES LABELS "${ARG_LABELS}" TIMEOUT ${ARG_TIMEOUT}
                 ENVIRONMENT "FURN_EMBREE_CONFIG=isa=${isa}"
      TEST_FILTER "${ARG_ISA_FILTER}"
      DISCOVERY_TIMEOUT 60)
  endforeach()
  foreach(isa IN LISTS ARG_TORCH_ISAS)
    gtest_discover_tests(${target}
      TEST_PREFIX "${ARG_FOLDER}/${ARG_NAME}[torch-${isa}]."
      PROPERTIES LABELS "${ARG_LABELS}" TIMEOUT ${ARG_TIMEOUT}
                 ENVIRONMENT "FURN_TORCH_ISA=${isa}"
      TEST_FILTER "${ARG_ISA_FILTER}"
      DISCOVERY_TIMEOUT 60)
  endforeach()
  # The vote network's arithmetic: the suite pins fp32 (tests/test_main.cc);
  # a [bf16] variant runs PRECISION_FILTER's tests with auto meaning bf16
  # (skipped on a CPU without it). Select them with ctest -R '\[bf16\]'.
  if(NOT ARG_PRECISION_FILTER)
    set(ARG_PRECISION_FILTER "*")
  endif()
  foreach(precision IN LISTS ARG_PRECISIONS)
    gtest_discover_tests(${target}
      TEST_PREFIX "${ARG_FOLDER}/${ARG_NAME}[${precision}]."
      PROPERTIES LABELS "${ARG_LABELS}" TIMEOUT ${ARG_TIMEOUT}
                 ENVIRONMENT "FURN_NETWORK_PRECISION=${precision}"
      TEST_FILTER "${ARG_PRECISION_FILTER}"
      DISCOVERY_TIMEOUT 60)
  endforeach()
endfunction()
