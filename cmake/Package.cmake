# What an installation holds beside the programs and their data (each program's install rule is
# beside it in tools/, the shaders' and presets' in skylit_data_files), and the Debian package
# made of it (`make package`, docs/install.md):
#   bin/                              the programs
#   share/skylit/                     shaders, presets.yaml
#   share/skylit/examples/            the sample site, demo and node configs, HMD and IMU profiles,
#                                     the gate model and the park sky: copy it to run them
#   lib/systemd/system/               skylit-live.service, skylit-sky-node.service
#   share/doc/skylit/                 copyright, changelog.gz
#   share/man/man1/                   a manual page per program (help2man)
include(GNUInstallDirs)

install(DIRECTORY ${CMAKE_SOURCE_DIR}/config/ DESTINATION share/skylit/examples/config
        FILES_MATCHING PATTERN "*.yaml")
install(FILES ${CMAKE_SOURCE_DIR}/data/models/gate.glb DESTINATION share/skylit/examples/data/models)
install(FILES ${CMAKE_SOURCE_DIR}/data/hdri/park.exr DESTINATION share/skylit/examples/data/hdri)

# The units of config/ name /usr/local/bin (a source install's prefix) and say how to install
# them by hand; installed, they name the prefix's bin/ and say where they came from.
install(CODE "set(SKYLIT_UNITS \"${CMAKE_SOURCE_DIR}/config/skylit-live.service;${CMAKE_SOURCE_DIR}/config/skylit-sky-node.service\")")
install(SCRIPT ${CMAKE_SOURCE_DIR}/cmake/InstallUnits.cmake)

# A manual page per program, made by help2man from its --help and --version once it is built.
find_program(HELP2MAN help2man)
if(HELP2MAN)
  get_property(programs GLOBAL PROPERTY SKYLIT_INSTALLED_PROGRAMS)
  set(pages "")
  foreach(program IN LISTS programs)
    set(page ${CMAKE_BINARY_DIR}/man/${program}.1.gz)
    add_custom_command(OUTPUT ${page}
      COMMAND ${CMAKE_COMMAND} -DPROGRAM=$<TARGET_FILE:${program}> -DHELP2MAN=${HELP2MAN} -DOUT=${page}
              -P ${CMAKE_SOURCE_DIR}/cmake/ManPage.cmake
      DEPENDS ${program} ${CMAKE_SOURCE_DIR}/cmake/ManPage.cmake VERBATIM)
    list(APPEND pages ${page})
  endforeach()
  add_custom_target(skylit_man_pages ALL DEPENDS ${pages})
  install(FILES ${pages} DESTINATION share/man/man1)
else()
  message(STATUS "help2man not found: the programs are installed without manual pages (scripts/install-deps.sh installs it)")
endif()

set(SKYLIT_CHANGELOG_GZ ${CMAKE_BINARY_DIR}/packaging/changelog.gz)
add_custom_command(OUTPUT ${SKYLIT_CHANGELOG_GZ}
  COMMAND ${CMAKE_COMMAND} -E make_directory ${CMAKE_BINARY_DIR}/packaging
  COMMAND sh -c "gzip -9nc '${CMAKE_SOURCE_DIR}/packaging/debian/changelog' > '${SKYLIT_CHANGELOG_GZ}'"
  DEPENDS ${CMAKE_SOURCE_DIR}/packaging/debian/changelog VERBATIM)
add_custom_target(skylit_changelog ALL DEPENDS ${SKYLIT_CHANGELOG_GZ})
install(FILES ${CMAKE_SOURCE_DIR}/packaging/debian/copyright ${SKYLIT_CHANGELOG_GZ} DESTINATION share/doc/skylit)

set(CPACK_GENERATOR DEB)
set(CPACK_PACKAGE_NAME skylit)
set(CPACK_PACKAGE_VERSION ${PROJECT_VERSION})
set(CPACK_PACKAGING_INSTALL_PREFIX /usr)
set(CPACK_PACKAGE_DIRECTORY ${CMAKE_BINARY_DIR})
set(CPACK_STRIP_FILES ON)
set(CPACK_PACKAGE_DESCRIPTION_SUMMARY "mixed-reality compositor for outdoor heritage sites")
set(CPACK_PACKAGE_DESCRIPTION
    "skylit shows a lost or planned building where it stood, lit by today's sky,\n"
    "on a video see-through HMD: an offline baker of basis shadow images over a\n"
    "geodesic sky dome, a live service that turns fisheye sky frames into shadow\n"
    "ratios on the GPU and composites the building and its shadows onto the HMD\n"
    "camera, a sky node that shares one sky with many HMDs over MQTT, and\n"
    "calibration tools for installers.")
string(REPLACE ";" "" CPACK_PACKAGE_DESCRIPTION "${CPACK_PACKAGE_DESCRIPTION}")
set(CPACK_DEBIAN_FILE_NAME DEB-DEFAULT)  # skylit_<version>_amd64.deb
set(CPACK_DEBIAN_PACKAGE_MAINTAINER "the skylit developers <skylit@skylit.dev>")
set(CPACK_DEBIAN_PACKAGE_SECTION science)
set(CPACK_DEBIAN_PACKAGE_PRIORITY optional)
set(CPACK_DEBIAN_PACKAGE_HOMEPAGE "https://skylit.dev")
# The libraries the programs link, found by dpkg-shlibdeps; besides them, what postinst runs and
# the GL drivers EGL loads at run time (which no link names).
set(CPACK_DEBIAN_PACKAGE_SHLIBDEPS ON)
set(CPACK_DEBIAN_PACKAGE_DEPENDS "adduser, init-system-helpers (>= 1.50), libegl-mesa0, libgl1-mesa-dri")
set(CPACK_DEBIAN_PACKAGE_RECOMMENDS "mosquitto, ffmpeg")
set(CPACK_DEBIAN_PACKAGE_CONTROL_EXTRA
    ${CMAKE_SOURCE_DIR}/packaging/debian/postinst ${CMAKE_SOURCE_DIR}/packaging/debian/prerm
    ${CMAKE_SOURCE_DIR}/packaging/debian/postrm)
set(CPACK_DEBIAN_PACKAGE_CONTROL_STRICT_PERMISSION ON)
set(CPACK_INSTALL_DEFAULT_DIRECTORY_PERMISSIONS
    OWNER_READ OWNER_WRITE OWNER_EXECUTE GROUP_READ GROUP_EXECUTE WORLD_READ WORLD_EXECUTE)
include(CPack)
