#pragma once
// Where the programs find skylit's shared data (shaders, presets): share/skylit beside their
// bin/ folder, laid out alike in the build tree and in an installation (/usr, /usr/local, an
// unpacked package), so that no path of the source tree is compiled in.
#include <filesystem>

namespace skylit {

// SKYLIT_DATA_DIR when set, else <this program's folder>/../share/skylit. Not checked: a caller
// that misses a file there names it and this folder in its error.
std::filesystem::path data_dir();

}  // namespace skylit
