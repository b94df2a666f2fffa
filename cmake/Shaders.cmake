# GLSL -> SPIR-V at build time, embedded as a uint32_t array in a generated header.
#   coneshadow_shaders(<target> SOURCES a.comp b.vert ... [DEFINES X=1 ...])
# For <folder>/<name>.<stage> it writes ${CMAKE_BINARY_DIR}/gen/<folder>/<name>.<stage>.h holding
# `spv_<name>_<stage>`; include it as "<folder>/<name>.<stage>.h". Shaders may #include files relative
# to the source root ("sort/common.glsl", "core/shared.h"); glslang writes the files each shader read
# into a depfile, so an edit to any of them rebuilds exactly the shaders that include it. A compile
# error fails the build with the shader's file:line.
set(CONESHADOW_GEN_DIR ${CMAKE_BINARY_DIR}/gen)

function(coneshadow_shaders target)
  cmake_parse_arguments(ARG "" "" "SOURCES;DEFINES" ${ARGN})
  file(RELATIVE_PATH folder ${CMAKE_SOURCE_DIR} ${CMAKE_CURRENT_SOURCE_DIR})
  set(outputs)
  set(defines)
  foreach(d ${ARG_DEFINES})
    list(APPEND defines -D${d})
  endforeach()
  foreach(src ${ARG_SOURCES})
    get_filename_component(fname ${src} NAME)
    string(REPLACE "." "_" var "spv_${fname}")
    set(out ${CONESHADOW_GEN_DIR}/${folder}/${fname}.h)
    add_custom_command(
      OUTPUT ${out}
      COMMAND ${CMAKE_COMMAND} -E make_directory ${CONESHADOW_GEN_DIR}/${folder}
      COMMAND Vulkan::glslangValidator -V --target-env vulkan1.2 -I${CMAKE_SOURCE_DIR} ${defines}
              --vn ${var} --depfile ${out}.d -o ${out} ${CMAKE_CURRENT_SOURCE_DIR}/${src}
      DEPENDS ${CMAKE_CURRENT_SOURCE_DIR}/${src}
      DEPFILE ${out}.d
      COMMENT "glslang ${folder}/${fname}"
      VERBATIM)
    list(APPEND outputs ${out})
  endforeach()
  add_custom_target(${target}_spirv DEPENDS ${outputs})
  add_dependencies(${target} ${target}_spirv)
  target_include_directories(${target} PUBLIC ${CONESHADOW_GEN_DIR})
endfunction()
