# Interface targets that carry Parallax's compile flags, and helpers to declare modules,
# tests and benchmarks in one line each.

add_library(plx_warnings INTERFACE)
target_compile_options(plx_warnings INTERFACE -Wall -Wextra -Wpedantic -Wshadow
    -Wnon-virtual-dtor -Wcast-align -Wunused -Woverloaded-virtual
    # GCC 12 reports false positives through std::variant and std::optional (Result<T>).
    $<$<CXX_COMPILER_ID:GNU>:-Wno-maybe-uninitialized>
    # Unity builds #include each .cpp into one file, and GCC then takes a class holding a type
    # of its .cpp's anonymous namespace for a header's class that other files could see.
    $<$<CXX_COMPILER_ID:GNU>:-Wno-subobject-linkage>
    # An ISA namespace is opened inline by the PTM kernel files (ptm/src/kernel_ns.h) and reopened
    # without the keyword by PLX_ISA_DECLARE, which the standard allows ([namespace.def]).
    $<$<CXX_COMPILER_ID:Clang>:-Wno-inline-namespace-reopened-noninline>)
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
# Runtime dispatch (libs/core/include/plx/core/cpu.h): the default build targets baseline x86-64
# and compiles each hot kernel once more per ISA tier (plx_add_isa_kernels). PLX_NATIVE builds
# everything for the build machine instead, kernels included; PLX_NO_SIMD keeps the scalar path
# alone.
if(CMAKE_SYSTEM_PROCESSOR MATCHES "^(x86_64|AMD64|amd64)$" AND NOT PLX_NO_SIMD)
    set(PLX_ISA_DISPATCH ON)
else()
    set(PLX_ISA_DISPATCH OFF)
endif()
set(PLX_ISA_FLAGS_scalar "")
set(PLX_ISA_FLAGS_avx2 -march=x86-64-v3)
set(PLX_ISA_FLAGS_avx512 -march=x86-64-v4 -mavx512vbmi)
if(PLX_NATIVE AND NOT PLX_NO_SIMD)
    target_compile_options(plx_opt INTERFACE -march=native)
    target_compile_definitions(plx_opt INTERFACE PLX_NATIVE_BUILD=1)
endif()
if(PLX_NO_SIMD)
    target_compile_definitions(plx_opt INTERFACE PLX_NO_SIMD=1)
endif()
if(PLX_ISA_DISPATCH)
    target_compile_definitions(plx_opt INTERFACE PLX_ISA_KERNELS=1)
endif()

add_library(plx_sanitize INTERFACE)
if(PLX_SANITIZE)
    target_compile_options(plx_sanitize INTERFACE -fsanitize=address,undefined
        -fno-sanitize-recover=undefined -fno-omit-frame-pointer)
    target_link_options(plx_sanitize INTERFACE -fsanitize=address,undefined)
endif()

# plx_network_glue_sources(FILES...): the translation units that instantiate Boost.Asio and
# Beast (the WebSocket and HTTP transports). Under the sanitizers they keep ASan but not UBSan:
# UBSan's checks on Beast's templates nearly double the compile time of the build's slowest
# files, and the bytes those transports hand over are decoded elsewhere (protocol, codec,
# database readers), with both sanitizers and fuzzed. Each file is its own translation unit so
# that the build runs it beside others.
function(plx_network_glue_sources)
    set_source_files_properties(${ARGN} PROPERTIES SKIP_UNITY_BUILD_INCLUSION ON)
    if(PLX_SANITIZE)
        set_source_files_properties(${ARGN} PROPERTIES COMPILE_OPTIONS -fno-sanitize=undefined)
    endif()
endfunction()

add_library(plx_flags INTERFACE)
target_link_libraries(plx_flags INTERFACE plx_warnings plx_opt plx_sanitize)

# plx_add_module(NAME SOURCES ... DEPS ...): library plx_NAME with public headers in include/,
# installed with its headers into the export set that ParallaxConfig.cmake loads (plx::NAME to a
# find_package(Parallax) user). The compile flags stay the build's own: an installed static
# library's private dependencies reach its users' link lines, and plx_flags means nothing there.
function(plx_add_module name)
    cmake_parse_arguments(ARG "" "" "SOURCES;DEPS;PRIVATE_DEPS" ${ARGN})
    add_library(plx_${name} STATIC ${ARG_SOURCES})
    add_library(plx::${name} ALIAS plx_${name})
    set_target_properties(plx_${name} PROPERTIES EXPORT_NAME ${name})
    target_include_directories(plx_${name}
        PUBLIC $<BUILD_INTERFACE:${CMAKE_CURRENT_SOURCE_DIR}/include>
               $<INSTALL_INTERFACE:${CMAKE_INSTALL_INCLUDEDIR}>
        PRIVATE ${CMAKE_CURRENT_SOURCE_DIR}/src)
    target_link_libraries(plx_${name} PUBLIC ${ARG_DEPS}
        PRIVATE $<BUILD_INTERFACE:plx_flags> ${ARG_PRIVATE_DEPS})
    install(TARGETS plx_${name} EXPORT ParallaxTargets
        ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR})
    install(DIRECTORY ${CMAKE_CURRENT_SOURCE_DIR}/include/ TYPE INCLUDE)
endfunction()

# Every registered test executable; a build preset that only tests builds this target alone.
add_custom_target(plx_test_suites)

# plx_add_test(NAME [KERNELS] SOURCES ... DEPS ...): one GoogleTest executable registered with
# CTest; its main comes from plx_test_main (libs/core/mains), which refuses an unknown
# PLX_FORCE_ISA. KERNELS marks a suite that runs hand-written SIMD kernels or checks them against
# their scalar reference; with PLX_KERNEL_TESTS_ONLY (the scalar preset) only those suites are
# built.
function(plx_add_test name)
    cmake_parse_arguments(ARG "KERNELS" "" "SOURCES;DEPS" ${ARGN})
    if(NOT PLX_BUILD_TESTS OR (PLX_KERNEL_TESTS_ONLY AND NOT ARG_KERNELS))
        return()
    endif()
    add_executable(${name} ${ARG_SOURCES})
    add_dependencies(plx_test_suites ${name})
    target_link_libraries(${name} PRIVATE ${ARG_DEPS} plx_test_main plx_flags)
    target_compile_definitions(${name} PRIVATE
        PLX_SHARED_DATA_DIR="${PLX_SHARED_DATA_DIR}"
        PLX_SOURCE_DIR="${PROJECT_SOURCE_DIR}"
        PLX_TEST_OUTPUT_DIR="${PROJECT_BINARY_DIR}/test-output")
    gtest_discover_tests(${name} DISCOVERY_TIMEOUT 60
        PROPERTIES ENVIRONMENT "PLX_TEST_OUTPUT_DIR=${PROJECT_BINARY_DIR}/test-output")
endfunction()

# plx_add_bench(NAME SOURCES ... DEPS ...): one Google Benchmark executable (not run by CTest).
# Its main comes from plx_bench_main (libs/core/mains), which refuses an unknown PLX_FORCE_ISA;
# a driver that defines its own main keeps it (a static library's object is only linked where
# it resolves something) and calls plx::mains::refuseUnknownForcedIsa itself.
function(plx_add_bench name)
    cmake_parse_arguments(ARG "" "" "SOURCES;DEPS" ${ARGN})
    if(NOT PLX_BUILD_BENCH)
        return()
    endif()
    add_executable(${name} ${ARG_SOURCES})
    target_link_libraries(${name} PRIVATE ${ARG_DEPS} plx_bench_main benchmark::benchmark
                                          plx_flags)
    target_compile_definitions(${name} PRIVATE PLX_SHARED_DATA_DIR="${PLX_SHARED_DATA_DIR}")
endfunction()

# plx_add_isa_kernels(TARGET KERNELS src/a.inl ...): compiles each kernel `.inl` once per ISA tier
# into TARGET, in generated translation units that carry that tier's flags and include
# <plx/core/isa_kernel.h> (which refuses to compile without them and names the namespace:
# isa_scalar, isa_avx2, isa_avx512). Dispatch code picks one with PLX_ISA_PICK.
#
# ISAS avx2 limits the vector tiers to those listed (scalar is always built): for kernels whose
# dispatch never picks a tier, so that it is not compiled for nothing.
function(plx_add_isa_kernels target)
    cmake_parse_arguments(ARG "" "" "KERNELS;ISAS" ${ARGN})
    set(all_isas scalar avx2 avx512)
    set(isas scalar)
    if(PLX_ISA_DISPATCH)
        if(ARG_ISAS)
            list(APPEND isas ${ARG_ISAS})
        else()
            list(APPEND isas avx2 avx512)
        endif()
    endif()
    foreach(kernel IN LISTS ARG_KERNELS)
        get_filename_component(PLX_KERNEL_PATH ${kernel} ABSOLUTE)
        get_filename_component(PLX_KERNEL_NAME ${kernel} NAME_WE)
        foreach(PLX_ISA IN LISTS isas)
            list(FIND all_isas ${PLX_ISA} PLX_ISA_LEVEL)
            if(PLX_ISA_LEVEL LESS 0)
                message(FATAL_ERROR "plx_add_isa_kernels: unknown ISA '${PLX_ISA}'")
            endif()
            set(out ${CMAKE_CURRENT_BINARY_DIR}/isa/${PLX_KERNEL_NAME}_${PLX_ISA}.cpp)
            configure_file(${PROJECT_SOURCE_DIR}/cmake/isa/kernel.cpp.in ${out} @ONLY)
            target_sources(${target} PRIVATE ${out})
            set_source_files_properties(${out} PROPERTIES
                COMPILE_OPTIONS "${PLX_ISA_FLAGS_${PLX_ISA}}"
                OBJECT_DEPENDS ${PLX_KERNEL_PATH})
        endforeach()
    endforeach()
endfunction()
