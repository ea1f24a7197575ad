#pragma once
// A file compiled into a program (cmake/EmbedFiles.cmake): the console's pages, served with no
// path to find at run time.
#include <string_view>

namespace skylit {

struct EmbeddedFile {
  std::string_view bytes;
};

}  // namespace skylit
