# dh_idl_library(<target> <idl files...>)
# Runs fastddsgen once over all IDL files at build time (they include each other, and fastddsgen
# regenerates included files, so one invocation avoids two commands writing the same output).
# Generated code lives only in the build tree.
function(dh_idl_library target)
  find_program(FASTDDSGEN fastddsgen REQUIRED)
  set(out_dir ${CMAKE_CURRENT_BINARY_DIR}/generated/dh/msg)
  file(MAKE_DIRECTORY ${out_dir})
  set(sources)
  set(abs_idls)
  foreach(idl IN LISTS ARGN)
    get_filename_component(abs ${idl} ABSOLUTE)
    get_filename_component(stem ${idl} NAME_WE)
    list(APPEND abs_idls ${abs})
    list(APPEND sources ${out_dir}/${stem}.cxx ${out_dir}/${stem}PubSubTypes.cxx
                        ${out_dir}/${stem}.h ${out_dir}/${stem}PubSubTypes.h)
  endforeach()
  add_custom_command(
    OUTPUT ${sources}
    COMMAND ${FASTDDSGEN} -replace -cs -I ${CMAKE_CURRENT_SOURCE_DIR} -d ${out_dir} ${abs_idls}
    DEPENDS ${abs_idls}
    COMMENT "fastddsgen ${ARGN}"
    VERBATIM)
  add_library(${target} STATIC ${sources})
  # Generated headers include each other by bare name; users include "dh/msg/<file>.h".
  target_include_directories(${target} SYSTEM PUBLIC ${CMAKE_CURRENT_BINARY_DIR}/generated ${out_dir})
  target_link_libraries(${target} PUBLIC fastrtps fastcdr)
  set_target_properties(${target} PROPERTIES POSITION_INDEPENDENT_CODE ON)
  target_compile_options(${target} PRIVATE -Wno-unused-parameter)
endfunction()
