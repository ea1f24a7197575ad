# Install-time half of cmake/Package.cmake: each unit in SKYLIT_UNITS, its ExecStart moved from
# /usr/local/bin to this installation's bin/ and its by-hand install notes replaced, written to
# lib/systemd/system under the prefix (within DESTDIR, as CPack and `cmake --install` set them).
foreach(unit IN LISTS SKYLIT_UNITS)
  get_filename_component(name "${unit}" NAME)
  file(READ "${unit}" text)
  # The comment block before [Unit] tells how to install the unit by hand: not for this copy.
  string(FIND "${text}" "[Unit]" start)
  string(SUBSTRING "${text}" ${start} -1 body)
  string(REPLACE "/usr/local/bin/" "${CMAKE_INSTALL_PREFIX}/bin/" body "${body}")
  set(header "# ${name}, installed by skylit: its config goes in /etc/skylit (docs/install.md).\n"
             "# Enable it once that is written: systemctl enable --now ${name}\n\n")
  string(REPLACE ";" "" header "${header}")
  set(destination "$ENV{DESTDIR}${CMAKE_INSTALL_PREFIX}/lib/systemd/system")
  message(STATUS "Installing: ${destination}/${name}")
  file(WRITE "${destination}/${name}" "${header}${body}")
endforeach()
