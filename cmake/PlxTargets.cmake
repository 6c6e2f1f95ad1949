# Interface targets that carry Parallax's compile flags, and helpers to declare modules,
# tests and benchmarks in one line each.

add_library(plx_warnings INTERFACE)
target_compile_options(plx_warnings INTERFACE -Wall -Wextra -Wpedantic -Wshadow
    -Wnon-virtual-dtor -Wcast-align -Wunused -Woverloaded-virtual
    # GCC 12 reports false positives through std::variant and std::optional (Result<T>).
    -Wno-maybe-uninitialized)
if(PLX_WERROR)
    target_compile_options(plx_warnings INTERFACE -Werror)
endif()

add_library(plx_opt INTERFACE)
# fp-contract=off: fast paths are tested bit-exactly against scalar references, which needs the
# same rounding in both; fused multiply-adds chosen by the compiler would differ between them.
# fno-math-errno: lets lrint, sqrt and friends inline as single instructions; nothing in Parallax
# reads errno after maths calls, and results are unchanged.
target_compile_options(plx_opt INTERFACE -ffp-contract=off -fno-math-errno
    $<$<CONFIG:Release>:-O3>)
if(PLX_NATIVE AND NOT PLX_NO_SIMD)
    target_compile_options(plx_opt INTERFACE -march=native)
endif()
if(PLX_NO_SIMD)
    target_compile_definitions(plx_opt INTERFACE PLX_NO_SIMD=1)
endif()

add_library(plx_sanitize INTERFACE)
if(PLX_SANITIZE)
    target_compile_options(plx_sanitize INTERFACE -fsanitize=address,undefined
        -fno-sanitize-recover=undefined -fno-omit-frame-pointer)
    target_link_options(plx_sanitize INTERFACE -fsanitize=address,undefined)
endif()

add_library(plx_flags INTERFACE)
target_link_libraries(plx_flags INTERFACE plx_warnings plx_opt plx_sanitize)

# plx_add_module(NAME SOURCES ... DEPS ...): library plx_NAME with public headers in include/.
function(plx_add_module name)
    cmake_parse_arguments(ARG "" "" "SOURCES;DEPS;PRIVATE_DEPS" ${ARGN})
    add_library(plx_${name} STATIC ${ARG_SOURCES})
    add_library(plx::${name} ALIAS plx_${name})
    target_include_directories(plx_${name}
        PUBLIC $<BUILD_INTERFACE:${CMAKE_CURRENT_SOURCE_DIR}/include>
        PRIVATE ${CMAKE_CURRENT_SOURCE_DIR}/src)
    target_link_libraries(plx_${name} PUBLIC ${ARG_DEPS} PRIVATE plx_flags ${ARG_PRIVATE_DEPS})
endfunction()

# plx_add_test(NAME SOURCES ... DEPS ...): one GoogleTest executable registered with CTest.
function(plx_add_test name)
    cmake_parse_arguments(ARG "" "" "SOURCES;DEPS" ${ARGN})
    if(NOT PLX_BUILD_TESTS)
        return()
    endif()
    add_executable(${name} ${ARG_SOURCES})
    target_link_libraries(${name} PRIVATE ${ARG_DEPS} GTest::gtest_main plx_flags)
    target_compile_definitions(${name} PRIVATE
        PLX_SHARED_DATA_DIR="${PLX_SHARED_DATA_DIR}"
        PLX_SOURCE_DIR="${PROJECT_SOURCE_DIR}"
        PLX_TEST_OUTPUT_DIR="${PROJECT_BINARY_DIR}/test-output")
    gtest_discover_tests(${name} DISCOVERY_TIMEOUT 60
        PROPERTIES ENVIRONMENT "PLX_TEST_OUTPUT_DIR=${PROJECT_BINARY_DIR}/test-output")
endfunction()

# plx_add_bench(NAME SOURCES ... DEPS ...): one Google Benchmark executable (not run by CTest).
function(plx_add_bench name)
    cmake_parse_arguments(ARG "" "" "SOURCES;DEPS" ${ARGN})
    if(NOT PLX_BUILD_BENCH)
        return()
    endif()
    add_executable(${name} ${ARG_SOURCES})
    target_link_libraries(${name} PRIVATE ${ARG_DEPS} benchmark::benchmark plx_flags)
    target_compile_definitions(${name} PRIVATE PLX_SHARED_DATA_DIR="${PLX_SHARED_DATA_DIR}")
endfunction()
