// Shader libraries: a line "// library: NAME.glsl" appends the library to the shader's text
// (after it, so the shader's own line numbers stay the file's), and programs link with it.
#include <gtest/gtest.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <string>
#include <unistd.h>

#include "../support/temp_dir.hpp"
#include "skylit/base/error.hpp"
#include "skylit/base/files.hpp"
#include "skylit/gpu/egl_context.hpp"
#include "skylit/gpu/shader.hpp"

namespace skylit::gpu {
namespace {

namespace fs = std::filesystem;

const fs::path kShaderDir = fs::path(SKYLIT_SOURCE_DIR) / "shaders";

using test::TempDir;

TEST(ShaderLibrary, TheLibraryIsAppendedAfterTheShader) {
  const std::string shader = read_file(kShaderDir / "sun_visibility.comp");
  const std::string library = read_file(kShaderDir / "sun_shadow.glsl");
  const std::string text = read_shader(kShaderDir, "sun_visibility.comp");
  EXPECT_EQ(text.substr(0, shader.size()), shader);
  EXPECT_NE(text.find(library, shader.size()), std::string::npos);
  // A shader without the line is read as it is.
  EXPECT_EQ(read_shader(kShaderDir, "blend.comp"), read_file(kShaderDir / "blend.comp"));
}

TEST(ShaderLibrary, ProgramsLinkWithTheirLibraries) {
  const HeadlessContext context;
  TempDir shaders;
  shaders.write("twice.glsl", "float twice(float x) { return 2.0 * x; }\n");
  shaders.write("uses.comp",
                "#version 310 es\n// library: twice.glsl\nlayout(local_size_x = 1) in;\n"
                "layout(std430, binding = 0) buffer B { float v[]; };\nfloat twice(float x);\n"
                "void main() { v[0] = twice(v[0]); }\n");
  const Program program = load_program(shaders.path(), {"uses.comp"});
  EXPECT_NE(program.get(), 0u);
  // And the project's own: the sun's visibility pass needs sun_shadow.glsl to link.
  EXPECT_NO_THROW(load_program(kShaderDir, {"sun_visibility.comp"}));
}

TEST(ShaderLibrary, MissingLibraryIsAnInputError) {
  TempDir shaders;
  shaders.write("lonely.comp", "#version 310 es\n// library: nowhere.glsl\nvoid main() {}\n");
  try {
    read_shader(shaders.path(), "lonely.comp");
    FAIL() << "expected InputError";
  } catch (const InputError& error) {
    EXPECT_NE(std::string(error.what()).find("nowhere.glsl"), std::string::npos) << error.what();
  }
}

}  // namespace
}  // namespace skylit::gpu
