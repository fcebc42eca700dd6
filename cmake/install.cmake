# cmake --install BUILD --prefix P (docs/api.md "Installing"):
#   P/bin                    mocap-index, mocap-search, mocap-synth, mocap-synth-quality
#   P/lib                    libmocap_common.a, libmocap_player.a, libmocap_indexer.a, libmocap_search.a,
#                            libmocap_synth.a
#   P/include/mocap/LIBRARY  the public headers (LIBRARY/include of each library)
#   P/lib/cmake/mocap        mocapConfig.cmake: find_package(mocap) gives mocap::common,
#                            mocap::player, mocap::indexer, mocap::search and mocap::synth
# Other parts add their own rules (a component each).
include(CMakePackageConfigHelpers)

set(MOCAP_CMAKE_DIR ${CMAKE_INSTALL_LIBDIR}/cmake/mocap)
set(mocap_libraries mocap_common mocap_player mocap_indexer mocap_search mocap_synth)
set(mocap_programs mocap-index mocap-search mocap-synth mocap-synth-quality)

install(TARGETS ${mocap_libraries} EXPORT mocapTargets
        ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR}
        LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR}
        RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})
install(TARGETS ${mocap_programs} RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})
foreach(library common common/player indexer search synth)
  install(DIRECTORY ${PROJECT_SOURCE_DIR}/${library}/include/
          DESTINATION ${CMAKE_INSTALL_INCLUDEDIR} FILES_MATCHING PATTERN "*.hpp")
endforeach()

install(EXPORT mocapTargets NAMESPACE mocap:: DESTINATION ${MOCAP_CMAKE_DIR})
configure_package_config_file(${CMAKE_CURRENT_LIST_DIR}/mocapConfig.cmake.in
                              ${PROJECT_BINARY_DIR}/mocapConfig.cmake
                              INSTALL_DESTINATION ${MOCAP_CMAKE_DIR})
# 0.x: a minor version may change the API.
write_basic_package_version_file(${PROJECT_BINARY_DIR}/mocapConfigVersion.cmake
                                 VERSION ${PROJECT_VERSION} COMPATIBILITY SameMinorVersion)
install(FILES ${PROJECT_BINARY_DIR}/mocapConfig.cmake ${PROJECT_BINARY_DIR}/mocapConfigVersion.cmake
        DESTINATION ${MOCAP_CMAKE_DIR})
