# ips_lcm_gen_cpp(<target> OUT_DIR <dir> SOURCES <file.lcm>...)
#
# Generates C++ headers from LCM definitions with lcm-gen and makes their decoders safe on hostile input
# (cmake/lcm_bound_lengths.cmake): a declared string length or array count is checked against the bytes the
# datagram still holds before anything is allocated from it. Without this, lcm-gen 1.3.1's decoder resizes
# a vector to whatever count a packet declares (2^31 bytes from a 100-byte message) and passes a length of 0
# or below straight to std::string::assign (an exception and signed overflow).
# Defines an INTERFACE library <target> whose include directory holds the headers.
# ips_lcm_type_files(<out_var> DIR <dir> EXT <ext> SOURCES <file.lcm>...): the file lcm-gen writes for every
# struct of the sources, <dir>/<package path>/<type>.<ext>.
function(ips_lcm_type_files out_var)
  cmake_parse_arguments(ARG "" "DIR;EXT" "SOURCES" ${ARGN})
  set(files "")
  foreach(src ${ARG_SOURCES})
    file(STRINGS ${src} pkg_line REGEX "^package ")
    string(REGEX MATCH "^package ([a-z_0-9.]+)" _m "${pkg_line}")
    string(REPLACE "." "/" pkg_dir "${CMAKE_MATCH_1}")
    file(STRINGS ${src} struct_lines REGEX "^struct ")
    foreach(line ${struct_lines})
      string(REGEX REPLACE "^struct ([A-Za-z_0-9]+).*" "\\1" type "${line}")
      list(APPEND files ${ARG_DIR}/${pkg_dir}/${type}.${ARG_EXT})
    endforeach()
  endforeach()
  set(${out_var} ${files} PARENT_SCOPE)
endfunction()

function(ips_lcm_gen_cpp target)
  cmake_parse_arguments(ARG "" "OUT_DIR" "SOURCES" ${ARGN})
  ips_lcm_type_files(headers DIR ${ARG_OUT_DIR} EXT hpp SOURCES ${ARG_SOURCES})
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
  # LCM's coretypes decode a double by writing it through an int64_t pointer. Under strict aliasing the compiler
  # may keep a value it knows from before the decode (seen: a value-initialised ground_truth_t read back as
  # zeros after a successful decode at -O3), so every user of the generated types compiles without that rule.
  target_compile_options(${target} INTERFACE -fno-strict-aliasing)
endfunction()

# ips_lcm_gen_java(<target> JAR <file.jar> SOURCES <file.lcm>...): the Java classes of the types in a jar, so that
# lcm-spy decodes them. Defines target <target> (built by default). Needs javac and LCM_JAR (liblcm-java).
function(ips_lcm_gen_java target)
  cmake_parse_arguments(ARG "" "JAR" "SOURCES" ${ARGN})
  set(java_out ${CMAKE_CURRENT_BINARY_DIR}/${target}_java)
  set(classes ${CMAKE_CURRENT_BINARY_DIR}/${target}_classes)
  ips_lcm_type_files(java_sources DIR ${java_out} EXT java SOURCES ${ARG_SOURCES})
  get_filename_component(jar_dir ${ARG_JAR} DIRECTORY)
  add_custom_command(
    OUTPUT ${ARG_JAR}
    COMMAND ${CMAKE_COMMAND} -E rm -rf ${java_out} ${classes}
    COMMAND ${CMAKE_COMMAND} -E make_directory ${java_out} ${classes} ${jar_dir}
    COMMAND ${LCM_GEN} --java --jpath ${java_out} ${ARG_SOURCES}
    COMMAND ${Java_JAVAC_EXECUTABLE} -nowarn -cp ${LCM_JAR} -d ${classes} ${java_sources}
    COMMAND ${Java_JAR_EXECUTABLE} cf ${ARG_JAR} -C ${classes} .
    DEPENDS ${ARG_SOURCES}
    COMMENT "lcm-gen --java and javac: ${ARG_JAR}"
    VERBATIM)
  add_custom_target(${target} ALL DEPENDS ${ARG_JAR})
endfunction()
