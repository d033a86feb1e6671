# ips_add_module_folders(): adds every sub-folder of the current source folder that has a CMakeLists.txt, in name
# order, except the modules named in IPS_SKIP_MODULES. tools/ and tests/ hold one such folder per module.
function(ips_add_module_folders)
  file(GLOB subdirs LIST_DIRECTORIES true RELATIVE ${CMAKE_CURRENT_SOURCE_DIR} ${CMAKE_CURRENT_SOURCE_DIR}/*)
  list(SORT subdirs)
  foreach(dir ${subdirs})
    if(IS_DIRECTORY ${CMAKE_CURRENT_SOURCE_DIR}/${dir} AND EXISTS ${CMAKE_CURRENT_SOURCE_DIR}/${dir}/CMakeLists.txt
       AND NOT dir IN_LIST IPS_SKIP_MODULES)
      add_subdirectory(${dir})
    endif()
  endforeach()
endfunction()
