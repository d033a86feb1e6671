# ips_lcm_gen_cpp(<target> OUT_DIR <dir> SOURCES <file.lcm>...)
#
# Generates C++ headers from LCM definitions with lcm-gen and makes their decoders safe on hostile input
# (cmake/lcm_bound_lengths.cmake): a declared string length or array count is checked against the bytes the
# datagram still holds before anything is allocated from it. Without this, lcm-gen 1.3.1's decoder resizes
# a vector to whatever count a packet declares (2^31 bytes from a 100-byte message) and passes a length of 0
# or below straight to std::string::assign (an exception and signed overflow).
# Defines an INTERFACE library <target> whose include directory holds the headers.
function(ips_lcm_gen_cpp target)
  cmake_parse_arguments(ARG "" "OUT_DIR" "SOURCES" ${ARGN})
  set(headers "")
  foreach(src ${ARG_SOURCES})
    file(STRINGS ${src} pkg_line REGEX "^package ")
    string(REGEX MATCH "^package ([a-z_0-9.]+)" _m "${pkg_line}")
    string(REPLACE "." "/" pkg_dir "${CMAKE_MATCH_1}")
    file(STRINGS ${src} struct_lines REGEX "^struct ")
    foreach(line ${struct_lines})
      string(REGEX REPLACE "^struct ([A-Za-z_0-9]+).*" "\\1" type "${line}")
      list(APPEND headers ${ARG_OUT_DIR}/${pkg_dir}/${type}.hpp)
    endforeach()
  endforeach()
  add_custom_command(
    OUTPUT ${headers}
    COMMAND ${CMAKE_COMMAND} -E make_directory ${ARG_OUT_DIR}
    COMMAND ${LCM_GEN} --cpp --cpp-hpath ${ARG_OUT_DIR} ${ARG_SOURCES}
    COMMAND ${CMAKE_COMMAND} "-DHEADERS=${headers}" -P ${IPS_CMAKE_DIR}/lcm_bound_lengths.cmake
    DEPENDS ${ARG_SOURCES} ${IPS_CMAKE_DIR}/lcm_bound_lengths.cmake
    COMMENT "lcm-gen --cpp ${target} (lengths bounded by the datagram)"
    VERBATIM)
  add_custom_target(${target}_gen DEPENDS ${headers})
  add_library(${target} INTERFACE)
  add_dependencies(${target} ${target}_gen)
  target_include_directories(${target} SYSTEM INTERFACE ${ARG_OUT_DIR})
  target_link_libraries(${target} INTERFACE PkgConfig::LCM)
endfunction()
