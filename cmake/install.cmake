# cmake --install [--prefix DIR]: the public headers, the two libraries
# (ek::ek: the kernels, OpenMP and libm; ek::sim: meshes, scenes,
# integrators and HDF5 frames, adding HDF5 and cJSON), the programs, the
# shipped scenes and meshes, ekConfig.cmake (+ version file and exported
# targets) and ek.pc / ek-sim.pc. README.md "Install" says why two
# libraries. Both are static archives, so their dependencies are part of
# what a consumer links (INTERFACE_LINK_LIBRARIES, pkg-config Libs and
# Requires, not Libs.private): nothing is added by hand.
include(CMakePackageConfigHelpers)

set(EK_INSTALL_CMAKEDIR ${CMAKE_INSTALL_LIBDIR}/cmake/ek)
set(EK_INSTALL_SCENESDIR ${CMAKE_INSTALL_DATADIR}/ek/scenes)

install(DIRECTORY ${PROJECT_SOURCE_DIR}/include/ek DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}
        FILES_MATCHING PATTERN "*.h")
install(TARGETS ek ek_sim EXPORT ekTargets ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR})
foreach(program ek-bench ek-sim ek-verify)
  if(TARGET ${program})
    # HDF5 may live outside the loader's default path (it is linked by
    # full path): keep that folder in the installed program's RUNPATH.
    set_target_properties(${program} PROPERTIES INSTALL_RPATH_USE_LINK_PATH TRUE)
    install(TARGETS ${program} RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})
  endif()
endforeach()
# The scenes with their meshes beside them (scene files name meshes
# relative to themselves); ek-sim and ek-bench find them from bin/
# (sim/scene_find.h).
install(DIRECTORY ${PROJECT_SOURCE_DIR}/scenes/ DESTINATION ${EK_INSTALL_SCENESDIR})

# CMake: find_package(ek) -> ek::ek, ek::sim, ek_SCENES_DIR.
install(EXPORT ekTargets FILE ekTargets.cmake NAMESPACE ek:: DESTINATION ${EK_INSTALL_CMAKEDIR})
configure_package_config_file(${CMAKE_CURRENT_LIST_DIR}/ekConfig.cmake.in
                              ${PROJECT_BINARY_DIR}/ekConfig.cmake
                              INSTALL_DESTINATION ${EK_INSTALL_CMAKEDIR}
                              PATH_VARS EK_INSTALL_SCENESDIR)
# 0.x: a minor version may change the API, so only the same minor matches.
write_basic_package_version_file(${PROJECT_BINARY_DIR}/ekConfigVersion.cmake
                                 COMPATIBILITY SameMinorVersion)
install(FILES ${PROJECT_BINARY_DIR}/ekConfig.cmake ${PROJECT_BINARY_DIR}/ekConfigVersion.cmake
        DESTINATION ${EK_INSTALL_CMAKEDIR})

# pkg-config: ek.pc (the kernels) and ek-sim.pc (requires ek). Paths are
# relative to the .pc file's folder (${pcfiledir}), so `cmake --install
# --prefix DIR` and a moved tree give the right ones.
file(RELATIVE_PATH EK_PC_PREFIX ${CMAKE_INSTALL_FULL_LIBDIR}/pkgconfig ${CMAKE_INSTALL_PREFIX})
string(REGEX REPLACE "/$" "" EK_PC_PREFIX "\${pcfiledir}/${EK_PC_PREFIX}")
foreach(dir INCLUDEDIR LIBDIR)
  if(IS_ABSOLUTE "${CMAKE_INSTALL_${dir}}")
    set(EK_PC_${dir} "${CMAKE_INSTALL_${dir}}")
  else()
    set(EK_PC_${dir} "\${prefix}/${CMAKE_INSTALL_${dir}}")
  endif()
endforeach()
if(IS_ABSOLUTE "${EK_INSTALL_SCENESDIR}")
  set(EK_PC_SCENESDIR "${EK_INSTALL_SCENESDIR}")
else()
  set(EK_PC_SCENESDIR "\${prefix}/${EK_INSTALL_SCENESDIR}")
endif()
set(EK_PC_OPENMP "${OpenMP_C_FLAGS}")
# HDF5 and cJSON through their own .pc files where pkg-config knows them
# (Debian's libhdf5-dev and libcjson-dev ship hdf5.pc and libcjson.pc),
# else the libraries CMake found.
set(EK_PC_SIM_REQUIRES "ek = ${PROJECT_VERSION}")
set(EK_PC_SIM_LIBS "")
find_package(PkgConfig QUIET)
if(PKG_CONFIG_FOUND)
  pkg_check_modules(EK_PC_HDF5 QUIET hdf5)
  pkg_check_modules(EK_PC_CJSON QUIET libcjson)
endif()
if(EK_PC_HDF5_FOUND)
  string(APPEND EK_PC_SIM_REQUIRES ", hdf5")
else()
  foreach(lib ${HDF5_C_LIBRARIES})
    string(APPEND EK_PC_SIM_LIBS " ${lib}")
  endforeach()
endif()
if(EK_PC_CJSON_FOUND)
  string(APPEND EK_PC_SIM_REQUIRES ", libcjson")
else()
  string(APPEND EK_PC_SIM_LIBS " -lcjson")
endif()
# PETSc (optional, the implicit loop's amg/direct solvers): its .pc file,
# and MPI's libraries, which PETSc's .pc does not name.
if(PETSC_FOUND)
  string(APPEND EK_PC_SIM_REQUIRES ", PETSc")
  foreach(lib ${MPI_C_LIBRARIES})
    string(APPEND EK_PC_SIM_LIBS " ${lib}")
  endforeach()
endif()
foreach(pc ek ek-sim)
  configure_file(${CMAKE_CURRENT_LIST_DIR}/${pc}.pc.in ${PROJECT_BINARY_DIR}/${pc}.pc @ONLY)
  install(FILES ${PROJECT_BINARY_DIR}/${pc}.pc DESTINATION ${CMAKE_INSTALL_LIBDIR}/pkgconfig)
endforeach()
