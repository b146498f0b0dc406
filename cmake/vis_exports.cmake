# vis_export_only(TARGET HEADER PREFIX): the shared library TARGET exports exactly the
# functions HEADER declares whose names start with PREFIX, and nothing else: a linker version
# script written from the header (re-read whenever it changes). Hidden visibility alone is not
# enough: GCC exports the ifunc symbols of target_clones functions whatever their visibility,
# and the C++ of the OpenVDB shim has no visibility markup at all.
function(vis_export_only target header prefix)
  set_property(DIRECTORY APPEND PROPERTY CMAKE_CONFIGURE_DEPENDS ${header})
  file(STRINGS ${header} decls REGEX "^[A-Za-z_][A-Za-z0-9_ ]*[ *]+${prefix}[a-z0-9_]*\\(")
  set(exports "")
  foreach(decl IN LISTS decls)
    if(decl MATCHES "^(static|typedef)[ \t]")
      continue()
    endif()
    if(decl MATCHES "(${prefix}[a-z0-9_]*)\\(")
      string(APPEND exports "    ${CMAKE_MATCH_1};\n")
    endif()
  endforeach()
  if(NOT exports)
    message(FATAL_ERROR "vis_export_only: no ${prefix}* function declarations found in ${header}")
  endif()
  get_filename_component(name ${header} NAME)
  set(map ${CMAKE_CURRENT_BINARY_DIR}/${target}.map)
  file(CONFIGURE OUTPUT ${map}
       CONTENT "/* Generated from ${name} by cmake/vis_exports.cmake: the exported functions. */\n{\n  global:\n${exports}  local: *;\n};\n")
  target_link_options(${target} PRIVATE LINKER:--version-script=${map})
  set_property(TARGET ${target} APPEND PROPERTY LINK_DEPENDS ${map})
endfunction()
