# The install test: `cmake --install` of this build into a scratch prefix, then two programs
# outside the project built against it, one through find_package(libvis) (libvis::vis) and
# one through pkg-config, and run.
#
# Included by tests/CMakeLists.txt, this file registers the CTest test "install"; run by that
# test with `cmake -P`, it does the work (CMAKE_SCRIPT_MODE_FILE tells the two apart).

if(NOT CMAKE_SCRIPT_MODE_FILE)
  find_program(VIS_PKG_CONFIG NAMES pkg-config pkgconf)
  set(_install_sanitize_flags "")
  if(VIS_SANITIZE)
    # The installed libvis.a is instrumented: its consumers must link the sanitizer runtimes.
    set(_install_sanitize_flags "-fsanitize=address,undefined")
  endif()
  add_test(NAME install
    COMMAND ${CMAKE_COMMAND}
      -DBUILD_DIR=${PROJECT_BINARY_DIR}
      -DCONSUMER_DIR=${CMAKE_CURRENT_SOURCE_DIR}/install_consumer
      -DWORK_DIR=${CMAKE_CURRENT_BINARY_DIR}/install-test
      -DLIBDIR=${CMAKE_INSTALL_LIBDIR}
      -DC_COMPILER=${CMAKE_C_COMPILER}
      -DPKG_CONFIG=${VIS_PKG_CONFIG}
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
file(REMOVE_RECURSE ${WORK_DIR})
file(MAKE_DIRECTORY ${WORK_DIR})

run_step("cmake --install into ${prefix}" ${CMAKE_COMMAND} --install ${BUILD_DIR} --prefix ${prefix})
foreach(f include/vis/vis.h include/vis/vis_config.h ${LIBDIR}/libvis.a
          ${LIBDIR}/cmake/libvis/libvisConfig.cmake ${LIBDIR}/pkgconfig/libvis.pc)
  if(NOT EXISTS ${prefix}/${f})
    message(FATAL_ERROR "install test: ${f} was not installed")
  endif()
endforeach()

# 1. CMake: find_package(libvis) -> libvis::vis. Only the scratch prefix is searched.
set(cmake_build ${WORK_DIR}/find-package)
run_step("configure the find_package consumer"
  ${CMAKE_COMMAND} -S ${CONSUMER_DIR} -B ${cmake_build}
    -DCMAKE_BUILD_TYPE=Release -DCMAKE_C_COMPILER=${C_COMPILER}
    -DCMAKE_PREFIX_PATH=${prefix} -DCMAKE_FIND_USE_PACKAGE_REGISTRY=OFF
    "-DCMAKE_C_FLAGS=${EXTRA_FLAGS}" "-DCMAKE_EXE_LINKER_FLAGS=${EXTRA_FLAGS}")
run_step("build the find_package consumer" ${CMAKE_COMMAND} --build ${cmake_build})
run_step("run the find_package consumer" ${cmake_build}/consumer)
message(STATUS "${STEP_OUTPUT}")

# 2. pkg-config, the way a Makefile would: cc main.c $(pkg-config --cflags --libs --static libvis).
#    The .pc file names the configured prefix; the scratch prefix stands in for it.
if(NOT PKG_CONFIG)
  message(FATAL_ERROR "install test: pkg-config was not found")
endif()
set(ENV{PKG_CONFIG_PATH} ${prefix}/${LIBDIR}/pkgconfig)
set(ENV{PKG_CONFIG_LIBDIR} ${prefix}/${LIBDIR}/pkgconfig)
run_step("pkg-config --cflags libvis" ${PKG_CONFIG} --cflags libvis)
string(STRIP "${STEP_OUTPUT}" cflags)
run_step("pkg-config --libs --static libvis" ${PKG_CONFIG} --libs --static libvis)
string(STRIP "${STEP_OUTPUT}" libs)
separate_arguments(cflags UNIX_COMMAND "${cflags}")
separate_arguments(libs UNIX_COMMAND "${libs}")
separate_arguments(extra UNIX_COMMAND "${EXTRA_FLAGS}")
run_step("build the pkg-config consumer"
  ${C_COMPILER} -std=c11 ${extra} ${cflags} ${CONSUMER_DIR}/main.c -o ${WORK_DIR}/consumer-pkg-config ${libs})
run_step("run the pkg-config consumer" ${WORK_DIR}/consumer-pkg-config)
message(STATUS "${STEP_OUTPUT}")
