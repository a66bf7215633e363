# solid_embed_files(OUT_CPP NAMESPACE FILES...): generates a C++ source that
# holds each file's bytes, so the library carries schemas/ with it and never
# reads them from the source tree at run time. Regenerated when a file changes.
function(solid_embed_files out_cpp)
  set(script "${CMAKE_CURRENT_FUNCTION_LIST_DIR}/SolidEmbedScript.cmake")
  add_custom_command(
    OUTPUT ${out_cpp}
    COMMAND ${CMAKE_COMMAND} -DOUT=${out_cpp} "-DFILES=${ARGN}" -P ${script}
    DEPENDS ${ARGN} ${script}
    COMMENT "Embedding ${ARGN}"
    VERBATIM)
endfunction()
