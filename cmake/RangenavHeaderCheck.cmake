# Compiles every public header on its own: one generated translation unit per header that
# includes just that header, so a header that forgets an include of its own fails here.
function(rangenav_add_header_check)
  file(GLOB_RECURSE headers RELATIVE "${PROJECT_SOURCE_DIR}/include"
       CONFIGURE_DEPENDS "${PROJECT_SOURCE_DIR}/include/rangenav/*.hpp")
  set(sources)
  foreach(header IN LISTS headers)
    # The Vatti backend needs the optional Clipper library (checked below when it is found).
    if(header STREQUAL "rangenav/geometry/vatti_clipper.hpp" AND NOT TARGET rangenav::clipper)
      continue()
    endif()
    string(MAKE_C_IDENTIFIER "${header}" name)
    set(tu "${PROJECT_BINARY_DIR}/header_check/${name}.cpp")
    file(CONFIGURE OUTPUT "${tu}" CONTENT "#include <${header}>\n")
    list(APPEND sources "${tu}")
  endforeach()
  add_library(rangenav_header_check OBJECT ${sources})
  target_link_libraries(rangenav_header_check PRIVATE rangenav::rangenav)
  if(TARGET rangenav::clipper)
    target_link_libraries(rangenav_header_check PRIVATE rangenav::clipper)
  endif()
  rangenav_set_warnings(rangenav_header_check)
  # Nothing here runs: compile without optimisation, debug information or sanitizers (a build's
  # CMAKE_CXX_FLAGS may ask for them), which only cost time.
  target_compile_options(rangenav_header_check PRIVATE -O0 -g0)
  if(CMAKE_CXX_COMPILER_ID MATCHES "Clang|GNU")
    target_compile_options(rangenav_header_check PRIVATE -fno-sanitize=all)
  endif()
endfunction()
