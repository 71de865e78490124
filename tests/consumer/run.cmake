# ctest install_consumer (cmake -P, arguments from tests/CMakeLists.txt):
# `cmake --install` of this build into a fresh prefix under WORK_DIR, then,
# against that prefix only:
#   1. the installed tree has its headers, libraries, programs, scenes,
#      ekConfig.cmake (+ version, targets) and ek.pc / ek-sim.pc;
#   2. consumer.c (the simulation library, ek::sim) and consumer_kernels.c
#      (the kernels alone, <ek/ek.h> and ek::ek) built out of tree with
#      find_package(ek) (CMake) and run;
#   3. the same with `pkg-config --cflags --libs ek-sim` and `... ek` (the
#      kernels' flags only: no libek_sim, HDF5 or cJSON) and run;
#   4. the installed ek-sim and ek-bench find the installed scenes (from
#      WORK_DIR, not the source tree), EK_SCENES_DIR overrides, and a scene
#      not found is an error naming the paths tried.
# Any failure stops with the step, its command, exit status and output.
# The consumer is compiled with this build's C and linker flags (C_FLAGS,
# LINKER_FLAGS): a sanitizer build's archives need the sanitizer's runtime.
cmake_minimum_required(VERSION 3.20)
foreach(var BUILD_DIR WORK_DIR SOURCE_DIR C_COMPILER BINDIR LIBDIR INCLUDEDIR DATADIR)
  if(NOT DEFINED ${var})
    message(FATAL_ERROR "run.cmake: -D${var}=... is missing")
  endif()
endforeach()
set(prefix ${WORK_DIR}/prefix)
set(scenes ${prefix}/${DATADIR}/ek/scenes)

# step(NAME [FAIL] [CONTAINS text]... [STDERR_CONTAINS text]... COMMAND ...):
# runs COMMAND in WORK_DIR; it must exit 0 (non-zero with FAIL), and its
# stdout / stderr must contain each text given.
function(step name)
  cmake_parse_arguments(S "FAIL" "" "CONTAINS;STDERR_CONTAINS;COMMAND" ${ARGN})
  execute_process(COMMAND ${S_COMMAND} WORKING_DIRECTORY ${WORK_DIR} RESULT_VARIABLE rc
                  OUTPUT_VARIABLE out ERROR_VARIABLE err)
  string(REPLACE ";" " " cmd "${S_COMMAND}")
  set(ok TRUE)
  if(S_FAIL AND rc STREQUAL "0")
    set(ok FALSE)
    set(why "exit 0, expected a failure")
  elseif(NOT S_FAIL AND NOT rc STREQUAL "0")
    set(ok FALSE)
    set(why "exit ${rc}")
  endif()
  foreach(text ${S_CONTAINS})
    string(FIND "${out}" "${text}" at)
    if(at EQUAL -1)
      set(ok FALSE)
      string(APPEND why "; stdout lacks \"${text}\"")
    endif()
  endforeach()
  foreach(text ${S_STDERR_CONTAINS})
    string(FIND "${err}" "${text}" at)
    if(at EQUAL -1)
      set(ok FALSE)
      string(APPEND why "; stderr lacks \"${text}\"")
    endif()
  endforeach()
  if(NOT ok)
    message(FATAL_ERROR "FAIL ${name}: ${why}\n  command: ${cmd}\n--- stdout\n${out}\n--- stderr\n${err}")
  endif()
  message(STATUS "ok   ${name} (exit ${rc})")
  set(step_out "${out}" PARENT_SCOPE)
endfunction()

file(REMOVE_RECURSE ${WORK_DIR})
file(MAKE_DIRECTORY ${WORK_DIR})
unset(ENV{EK_SCENES_DIR})

step("cmake --install into ${prefix}" COMMAND ${CMAKE_COMMAND} --install ${BUILD_DIR} --prefix ${prefix})
foreach(file ${INCLUDEDIR}/ek/ek.h ${INCLUDEDIR}/ek/svd3.h ${INCLUDEDIR}/ek/sim/sim.h
        ${INCLUDEDIR}/ek/sim/scene.h ${INCLUDEDIR}/ek/sim/frames.h ${INCLUDEDIR}/ek/sim/mesh.h
        ${INCLUDEDIR}/ek/sim/trimesh.h
        ${LIBDIR}/libek.a ${LIBDIR}/libek_sim.a ${BINDIR}/ek-bench ${BINDIR}/ek-sim
        ${BINDIR}/ek-verify ${DATADIR}/ek/scenes/drop.json ${DATADIR}/ek/scenes/meshes/cube.node
        ${DATADIR}/ek/scenes/meshes/bracket.msh ${LIBDIR}/cmake/ek/ekConfig.cmake
        ${LIBDIR}/cmake/ek/ekConfigVersion.cmake ${LIBDIR}/cmake/ek/ekTargets.cmake
        ${LIBDIR}/pkgconfig/ek.pc ${LIBDIR}/pkgconfig/ek-sim.pc)
  if(NOT EXISTS ${prefix}/${file})
    message(FATAL_ERROR "FAIL install: ${prefix}/${file} is missing")
  endif()
endforeach()
message(STATUS "ok   installed tree has the headers, libraries, programs, scenes, config and .pc")

# 2. find_package(ek), and from this prefix (not another installed ek).
set(cmake_build ${WORK_DIR}/find_package)
step("consumer: configure with find_package(ek)"
     COMMAND ${CMAKE_COMMAND} -S ${SOURCE_DIR} -B ${cmake_build} -DCMAKE_PREFIX_PATH=${prefix}
             -DCMAKE_C_COMPILER=${C_COMPILER} "-DCMAKE_C_FLAGS=${C_FLAGS}"
             "-DCMAKE_EXE_LINKER_FLAGS=${LINKER_FLAGS}" -DCMAKE_BUILD_TYPE=Release)
file(STRINGS ${cmake_build}/CMakeCache.txt ek_dir REGEX "^ek_DIR:")
if(NOT ek_dir STREQUAL "ek_DIR:PATH=${prefix}/${LIBDIR}/cmake/ek")
  message(FATAL_ERROR "FAIL find_package(ek) found \"${ek_dir}\", not ${prefix}/${LIBDIR}/cmake/ek")
endif()
step("consumer: build (find_package)" COMMAND ${CMAKE_COMMAND} --build ${cmake_build})
step("consumer: run (find_package)" CONTAINS "PASS" "scene ${scenes}/drop.json"
     COMMAND ${cmake_build}/ek-consumer ${WORK_DIR}/find_package.h5)
step("kernels-only consumer: run (find_package, ek::ek)" CONTAINS "PASS"
     COMMAND ${cmake_build}/ek-consumer-kernels)

# 3. pkg-config, with only this prefix's .pc files added.
find_program(PKG_CONFIG NAMES pkg-config pkgconf)
if(NOT PKG_CONFIG)
  message(FATAL_ERROR "FAIL pkg-config not found (Debian package pkg-config)")
endif()
set(ENV{PKG_CONFIG_PATH} ${prefix}/${LIBDIR}/pkgconfig)
step("pkg-config --cflags --libs ek-sim" COMMAND ${PKG_CONFIG} --cflags --libs ek-sim)
separate_arguments(pc_flags UNIX_COMMAND "${step_out}")
separate_arguments(build_flags UNIX_COMMAND "${C_FLAGS} ${LINKER_FLAGS}")
step("pkg-config --variable=scenesdir ek" COMMAND ${PKG_CONFIG} --variable=scenesdir ek)
string(STRIP "${step_out}" pc_scenes)
step("consumer: compile and link with pkg-config's flags"
     COMMAND ${C_COMPILER} ${SOURCE_DIR}/consumer.c -o ${WORK_DIR}/ek-consumer-pc
             "-DEK_CONSUMER_SCENES=\"${pc_scenes}\"" ${build_flags} ${pc_flags} -lm)
step("consumer: run (pkg-config)" CONTAINS "PASS"
     COMMAND ${WORK_DIR}/ek-consumer-pc ${WORK_DIR}/pkg-config.h5)
step("pkg-config --cflags --libs ek" COMMAND ${PKG_CONFIG} --cflags --libs ek)
separate_arguments(pc_kernel_flags UNIX_COMMAND "${step_out}")
foreach(flag ${pc_kernel_flags})
  if(flag MATCHES "ek_sim|hdf5|cjson")
    message(FATAL_ERROR "FAIL pkg-config ek names ${flag}: the kernels need no libek_sim, HDF5 or cJSON")
  endif()
endforeach()
step("kernels-only consumer: compile and link with pkg-config ek's flags"
     COMMAND ${C_COMPILER} ${SOURCE_DIR}/consumer_kernels.c -o ${WORK_DIR}/ek-consumer-kernels-pc
             ${build_flags} ${pc_kernel_flags} -lm)
step("kernels-only consumer: run (pkg-config)" CONTAINS "PASS"
     COMMAND ${WORK_DIR}/ek-consumer-kernels-pc)

# 4. The installed programs and their scenes (WORK_DIR is the current folder).
# They print the path as found from /proc/self/exe, which has no links.
file(REAL_PATH ${scenes} scenes)
step("installed ek-sim finds a scene by name"
     CONTAINS "scene      ${scenes}/drop.json" COMMAND ${prefix}/${BINDIR}/ek-sim drop --explain)
step("installed ek-sim: an unknown scene names the paths tried" FAIL
     STDERR_CONTAINS "${scenes}/no_such_scene.json" COMMAND ${prefix}/${BINDIR}/ek-sim no_such_scene)
step("installed ek-bench lists the sim rows (every shipped scene loaded)"
     CONTAINS "sim/drop/" "sim/cantilever_implicit/"
     COMMAND ${prefix}/${BINDIR}/ek-bench --list --filter ^sim/)
set(ENV{EK_SCENES_DIR} ${WORK_DIR}/no_scenes_here)
step("installed ek-bench: EK_SCENES_DIR overrides, and is named when wrong" FAIL
     STDERR_CONTAINS "${WORK_DIR}/no_scenes_here/drop.json (\$EK_SCENES_DIR)"
     COMMAND ${prefix}/${BINDIR}/ek-bench --list --filter ^sim/drop/)
set(ENV{EK_SCENES_DIR} ${scenes})
step("installed ek-sim: EK_SCENES_DIR" CONTAINS "scene      ${scenes}/twist.json"
     COMMAND ${prefix}/${BINDIR}/ek-sim twist.json --explain)
