# The OpenCL kernels compiled by clang as OpenCL C 1.2 and as OpenCL C 2.0, whose generic
# address space NVIDIA's compiler uses. PoCL, which test_opencl runs on here, does not enforce
# address spaces that way: a pointer passed from a generic to a private parameter built on PoCL
# and failed on every NVIDIA GPU (docs/opencl.md, "the kernels did not build on NVIDIA").
# __OPENCL_VERSION__ is the platform's macro, which a driver defines and bare clang does not.
# Included by tests/CMakeLists.txt.
find_program(VIS_CLANG clang)
if(VIS_WITH_OPENCL AND VIS_KERNELS_CL AND VIS_CLANG)
  foreach(std 1.2 2.0)
    string(REPLACE "." "" _v "${std}")
    add_test(NAME opencl_kernels_cl${_v}
             COMMAND ${VIS_CLANG} -x cl -cl-std=CL${std} -Xclang -finclude-default-header -fsyntax-only
                     -Werror -D__OPENCL_VERSION__=${_v}0 ${VIS_KERNELS_CL})
  endforeach()
else()
  message(STATUS "OpenCL kernel compile checks: not registered (need the OpenCL backend and clang)")
endif()
