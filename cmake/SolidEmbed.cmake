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

# solid_build_commit_source(OUT_CPP): a target that rewrites OUT_CPP at every build with the
# commit the sources are at (cmake/SolidBuildCommitScript.cmake), so `solid --version` and the
# manifests name the commit a binary was built from, not the one CMake was configured at.
function(solid_build_commit_source out_cpp)
  set(script "${CMAKE_CURRENT_FUNCTION_LIST_DIR}/SolidBuildCommitScript.cmake")
  add_custom_target(solid_build_commit
    COMMAND ${CMAKE_COMMAND} -DOUT=${out_cpp} -DSOURCE_DIR=${PROJECT_SOURCE_DIR} -P ${script}
    BYPRODUCTS ${out_cpp}
    COMMENT "Recording the build's commit"
    VERBATIM)
endfunction()
