# The install test: `cmake --install` of this build into a scratch prefix, then an outside
# program (tests/install_consumer: a .vox loaded, meshed, traced, edited, re-meshed, traced
# again, every pixel checked against an oracle) built against it twice, through
# find_package(libvis) (libvis::vis, libvis::voxelworld) and through a plain
# `pkg-config --libs libvis voxelworld` (no --static), and run. Also checked:
#  - the installed headers compile alone as strict C11 and C++;
#  - no installed library and no consumer needs libOpenCL (readelf -d, ldd), and libvis.so has
#    no undefined cl* symbol (the ICD loader is opened at run time);
#  - each shared library exports exactly the functions its header declares (GCC's -aux-info
#    lists the header's declarations, nm -D the library's exports).
#
# Included by tests/CMakeLists.txt, this file registers the CTest test "install"; run by that
# test with `cmake -P`, it does the work (CMAKE_SCRIPT_MODE_FILE tells the two apart).

if(NOT CMAKE_SCRIPT_MODE_FILE)
  find_program(VIS_PKG_CONFIG NAMES pkg-config pkgconf)
  find_program(VIS_INSTALL_CXX NAMES c++ g++ clang++)
  find_program(VIS_READELF NAMES readelf)
  find_program(VIS_NM NAMES nm)
  find_program(VIS_LDD NAMES ldd)
  set(_install_sanitize_flags "")
  if(VIS_SANITIZE)
    # The installed libraries are instrumented: their consumers must link the sanitizer runtimes.
    set(_install_sanitize_flags "-fsanitize=address,undefined")
  endif()
  add_test(NAME install
    COMMAND ${CMAKE_COMMAND}
      -DBUILD_DIR=${PROJECT_BINARY_DIR}
      -DCONSUMER_DIR=${CMAKE_CURRENT_SOURCE_DIR}/install_consumer
      -DWORK_DIR=${CMAKE_CURRENT_BINARY_DIR}/install-test
      -DLIBDIR=${CMAKE_INSTALL_LIBDIR}
      -DINSTALL_SHARED=${VIS_INSTALL_SHARED}
      -DWITH_OPENCL=${VIS_WITH_OPENCL}
      -DC_COMPILER=${CMAKE_C_COMPILER}
      -DC_COMPILER_ID=${CMAKE_C_COMPILER_ID}
      -DCXX_COMPILER=${VIS_INSTALL_CXX}
      -DPKG_CONFIG=${VIS_PKG_CONFIG}
      -DREADELF=${VIS_READELF}
      -DNM=${VIS_NM}
      -DLDD=${VIS_LDD}
      -DEXTRA_FLAGS=${_install_sanitize_flags}
      -P ${CMAKE_CURRENT_LIST_FILE})
  set_tests_properties(install PROPERTIES TIMEOUT 600)
  return()
endif()

# ---- script mode ----------------------------------------------------------------------------

function(run_step what)
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "install test: ${what} failed (${rc})\n${out}\n${err}")
  endif()
  message(STATUS "install test: ${what}: ok")
  set(STEP_OUTPUT "${out}" PARENT_SCOPE)
endfunction()

set(prefix ${WORK_DIR}/prefix)
set(libdir ${prefix}/${LIBDIR})
file(REMOVE_RECURSE ${WORK_DIR})
file(MAKE_DIRECTORY ${WORK_DIR})
separate_arguments(extra UNIX_COMMAND "${EXTRA_FLAGS}")

run_step("cmake --install into ${prefix}" ${CMAKE_COMMAND} --install ${BUILD_DIR} --prefix ${prefix})
set(expected include/vis/vis.h include/vis/vis_config.h include/voxelworld/vw.h
    ${LIBDIR}/cmake/libvis/libvisConfig.cmake ${LIBDIR}/cmake/libvis/libvisTargets.cmake
    ${LIBDIR}/pkgconfig/libvis.pc ${LIBDIR}/pkgconfig/voxelworld.pc)
if(INSTALL_SHARED)
  list(APPEND expected ${LIBDIR}/libvis.so ${LIBDIR}/libvis.so.0 ${LIBDIR}/libvoxelworld.so ${LIBDIR}/libvoxelworld.so.0)
else()
  list(APPEND expected ${LIBDIR}/libvis.a ${LIBDIR}/libvoxelworld.a)
endif()
foreach(f IN LISTS expected)
  if(NOT EXISTS ${prefix}/${f})
    message(FATAL_ERROR "install test: ${f} was not installed")
  endif()
endforeach()

# 1. The installed headers on their own, as strict C11 and as C++.
foreach(h vis/vis.h voxelworld/vw.h)
  string(MAKE_C_IDENTIFIER "${h}" hid)
  file(WRITE ${WORK_DIR}/${hid}.c "#include <${h}>\nint main(void) { return 0; }\n")
  run_step("${h} as strict C11" ${C_COMPILER} -std=c11 -pedantic-errors -Wall -Wextra -Werror -fsyntax-only
           -I${prefix}/include ${WORK_DIR}/${hid}.c)
  if(CXX_COMPILER)
    file(WRITE ${WORK_DIR}/${hid}.cpp "#include <${h}>\nint main() { return 0; }\n")
    run_step("${h} as C++11" ${CXX_COMPILER} -std=c++11 -pedantic-errors -Wall -Wextra -Werror -fsyntax-only
             -I${prefix}/include ${WORK_DIR}/${hid}.cpp)
  endif()
endforeach()

# 2. Each shared library exports exactly what its header declares. The declarations come from
#    the compiler (-aux-info writes every prototype it parsed, with its file), not from the
#    version script's own reading of the header.
if(INSTALL_SHARED AND NM AND C_COMPILER_ID STREQUAL "GNU")
  foreach(pair "vis/vis.h=libvis.so" "voxelworld/vw.h=libvoxelworld.so")
    string(REPLACE "=" ";" pair "${pair}")
    list(GET pair 0 h)
    list(GET pair 1 lib)
    string(MAKE_C_IDENTIFIER "${h}" hid)
    run_step("the prototypes of ${h}" ${C_COMPILER} -std=c11 -fsyntax-only -aux-info ${WORK_DIR}/${hid}.aux
             -I${prefix}/include ${WORK_DIR}/${hid}.c)
    file(STRINGS ${WORK_DIR}/${hid}.aux aux)
    set(declared "")
    foreach(line IN LISTS aux)
      # "/* PATH/vw.h:40:NC */ extern const char *vw_status_string (vw_status);" — static
      # inline functions are not exported and say "static".
      if(line MATCHES "/${h}:[0-9]+:[A-Z]+ \\*/ extern .*[ *]([A-Za-z_][A-Za-z0-9_]*) \\(")
        list(APPEND declared ${CMAKE_MATCH_1})
      endif()
    endforeach()
    run_step("nm -D ${lib}" ${NM} -D --defined-only ${libdir}/${lib})
    string(REPLACE "\n" ";" nm_lines "${STEP_OUTPUT}")
    set(exported "")
    foreach(line IN LISTS nm_lines)
      if(line MATCHES "^[0-9a-f]* *[A-Za-z] ([^ @]+)")
        list(APPEND exported ${CMAKE_MATCH_1})
      endif()
    endforeach()
    list(SORT declared)
    list(REMOVE_DUPLICATES declared)
    list(SORT exported)
    list(REMOVE_DUPLICATES exported)
    set(missing ${declared})
    list(REMOVE_ITEM missing ${exported})
    set(extra_syms ${exported})
    list(REMOVE_ITEM extra_syms ${declared})
    list(LENGTH declared nd)
    if(nd LESS 10 OR missing OR extra_syms)
      message(FATAL_ERROR "install test: ${lib} exports are not the ${nd} functions of ${h}\n"
                          "declared but not exported: ${missing}\nexported but not declared: ${extra_syms}")
    endif()
    message(STATUS "install test: ${lib} exports exactly the ${nd} functions of ${h}: ok")
  endforeach()
endif()

# 3. CMake: find_package(libvis) -> libvis::vis, libvis::voxelworld. Only the scratch prefix
#    is searched.
set(cmake_build ${WORK_DIR}/find-package)
run_step("configure the find_package consumer"
  ${CMAKE_COMMAND} -S ${CONSUMER_DIR} -B ${cmake_build}
    -DCMAKE_BUILD_TYPE=Release -DCMAKE_C_COMPILER=${C_COMPILER}
    -DCMAKE_PREFIX_PATH=${prefix} -DCMAKE_FIND_USE_PACKAGE_REGISTRY=OFF
    "-DCMAKE_C_FLAGS=${EXTRA_FLAGS}" "-DCMAKE_EXE_LINKER_FLAGS=${EXTRA_FLAGS}")
run_step("build the find_package consumer" ${CMAKE_COMMAND} --build ${cmake_build})
run_step("run the find_package consumer" ${cmake_build}/consumer)
message(STATUS "${STEP_OUTPUT}")

# 4. pkg-config, the way a Makefile would: cc main.c $(pkg-config --cflags --libs libvis
#    voxelworld), without --static. The .pc files find their prefix from their own place.
if(NOT PKG_CONFIG)
  message(FATAL_ERROR "install test: pkg-config was not found")
endif()
set(ENV{PKG_CONFIG_PATH} ${libdir}/pkgconfig)
set(ENV{PKG_CONFIG_LIBDIR} ${libdir}/pkgconfig)
run_step("pkg-config --cflags libvis voxelworld" ${PKG_CONFIG} --cflags libvis voxelworld)
string(STRIP "${STEP_OUTPUT}" cflags)
run_step("pkg-config --libs libvis voxelworld" ${PKG_CONFIG} --libs libvis voxelworld)
string(STRIP "${STEP_OUTPUT}" libs)
message(STATUS "install test: pkg-config --libs: ${libs}")
separate_arguments(cflags UNIX_COMMAND "${cflags}")
separate_arguments(libs UNIX_COMMAND "${libs}")
set(pc_consumer ${WORK_DIR}/consumer-pkg-config)
run_step("build the pkg-config consumer"
  ${C_COMPILER} -std=c11 -O2 ${extra} ${cflags} ${CONSUMER_DIR}/main.c -o ${pc_consumer} ${libs} -lm)
# A prefix outside the loader's path is found through LD_LIBRARY_PATH, as a user would.
run_step("run the pkg-config consumer" ${CMAKE_COMMAND} -E env LD_LIBRARY_PATH=${libdir} ${pc_consumer})
message(STATUS "${STEP_OUTPUT}")

# 5. libOpenCL is needed by nothing installed and by no consumer: libvis opens the ICD loader
#    at run time, so a CPU-only program links and starts without it.
if(NOT READELF)
  message(FATAL_ERROR "install test: readelf was not found")
endif()
set(binaries ${pc_consumer} ${cmake_build}/consumer)
if(INSTALL_SHARED)
  list(APPEND binaries ${libdir}/libvis.so ${libdir}/libvoxelworld.so)
endif()
foreach(bin IN LISTS binaries)
  run_step("readelf -d ${bin}" ${READELF} -d ${bin})
  if(STEP_OUTPUT MATCHES "NEEDED[^\n]*libOpenCL")
    message(FATAL_ERROR "install test: ${bin} needs libOpenCL:\n${STEP_OUTPUT}")
  endif()
endforeach()
if(LDD)
  run_step("ldd the pkg-config consumer" ${CMAKE_COMMAND} -E env LD_LIBRARY_PATH=${libdir} ${LDD} ${pc_consumer})
  if(STEP_OUTPUT MATCHES "libOpenCL")
    message(FATAL_ERROR "install test: the consumer loads libOpenCL:\n${STEP_OUTPUT}")
  endif()
  message(STATUS "install test: ldd of the pkg-config consumer has no libOpenCL: ok")
endif()
if(INSTALL_SHARED AND NM)
  run_step("nm -D --undefined-only libvis.so" ${NM} -D --undefined-only ${libdir}/libvis.so)
  if(STEP_OUTPUT MATCHES "[ \n]cl[A-Z][A-Za-z]*")
    message(FATAL_ERROR "install test: libvis.so calls OpenCL directly:\n${STEP_OUTPUT}")
  endif()
  if(WITH_OPENCL AND NOT STEP_OUTPUT MATCHES "dlopen")
    message(FATAL_ERROR "install test: libvis.so built with OpenCL does not dlopen its loader:\n${STEP_OUTPUT}")
  endif()
endif()
