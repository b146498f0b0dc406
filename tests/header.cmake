# The public header compiles on its own as strict C11 and as C++ (STYLE.md: one public header,
# extern "C"-safe). Included by tests/CMakeLists.txt.
find_program(VIS_HEADER_CXX NAMES c++ g++ clang++)
set(_vis_hdr_src "#include <vis/vis.h>\nint main(void) { vis_context *c = 0; (void)c; return (int)VIS_OK; }\n")
file(WRITE ${CMAKE_CURRENT_BINARY_DIR}/header_check.c "${_vis_hdr_src}")
file(WRITE ${CMAKE_CURRENT_BINARY_DIR}/header_check.cpp "${_vis_hdr_src}")
add_test(NAME header_c11
         COMMAND ${CMAKE_C_COMPILER} -std=c11 -pedantic-errors -Wall -Wextra -Werror -fsyntax-only
                 -I${PROJECT_SOURCE_DIR}/libvis/include -I${PROJECT_BINARY_DIR}/include
                 ${CMAKE_CURRENT_BINARY_DIR}/header_check.c)
if(VIS_HEADER_CXX)
  add_test(NAME header_cxx
           COMMAND ${VIS_HEADER_CXX} -std=c++11 -pedantic-errors -Wall -Wextra -Werror -fsyntax-only
                   -I${PROJECT_SOURCE_DIR}/libvis/include -I${PROJECT_BINARY_DIR}/include
                   ${CMAKE_CURRENT_BINARY_DIR}/header_check.cpp)
endif()
