// Shader loading: every shader in shaders/ compiles and links in the driver, errors point at the
// file and line, and the shader directory is found the documented way.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <set>
#include <string>
#include <vector>

#include "skylit/base/error.hpp"
#include "skylit/base/files.hpp"
#include "skylit/gpu/egl_context.hpp"
#include "skylit/gpu/gl.hpp"
#include "skylit/gpu/shader.hpp"

namespace skylit::gpu {
namespace shader_test {  // named, not anonymous: the test program is one unity build

namespace fs = std::filesystem;

const fs::path kShaderDir = fs::path(SKYLIT_SOURCE_DIR) / "shaders";

// The programs the project links. A new .vert/.frag must be added here (the test below fails
// until it is), so that every stage is also checked against its partner's interface.
const std::vector<std::vector<std::string>> kPipelines = {
    {"shadow_depth.vert", "shadow_depth.frag"},
    {"plane_texels.vert", "visibility.frag"},
    {"vertex_samples.vert", "visibility.frag"},
    {"compose_building.vert", "compose_building.frag"},
    {"compose_fullscreen.vert", "compose_final.frag"},
    {"compose_depth.vert", "compose_depth.frag"},
    {"hmd_distortion.vert", "hmd_distortion.frag"},
};

std::vector<fs::path> shader_files() {
  std::vector<fs::path> files;
  for (const fs::directory_entry& entry : fs::directory_iterator(kShaderDir)) {
    const std::string extension = entry.path().extension().string();
    if (extension == ".vert" || extension == ".frag" || extension == ".comp") files.push_back(entry.path().filename());
  }
  std::sort(files.begin(), files.end());
  return files;
}

class Shaders : public ::testing::Test {
 protected:
  HeadlessContext context_;
};

TEST_F(Shaders, EveryShaderCompilesInTheDriver) {
  const std::vector<fs::path> files = shader_files();
  ASSERT_FALSE(files.empty());
  for (const fs::path& file : files) {
    SCOPED_TRACE(file.string());
    const fs::path path = kShaderDir / file;
    EXPECT_NO_THROW(compile_shader({shader_stage(file), path.string(), read_file(path)}));
  }
}

TEST_F(Shaders, EveryShaderLinksInAProgram) {
  std::set<std::string> linked;
  for (const std::vector<std::string>& pipeline : kPipelines) {
    SCOPED_TRACE(pipeline.front() + " + " + pipeline.back());
    Program program;
    if (pipeline.size() == 2) {
      EXPECT_NO_THROW(program = load_program(kShaderDir, {pipeline[0], pipeline[1]}));
    }
    EXPECT_NE(program.get(), 0u);
    linked.insert(pipeline.begin(), pipeline.end());
  }
  for (const fs::path& file : shader_files()) {
    if (file.extension() == ".comp") {
      EXPECT_NO_THROW(load_program(kShaderDir, {file})) << file;
    } else {
      EXPECT_TRUE(linked.count(file.string()) == 1)
          << file << " is in no pipeline of tests/gpu/shader_test.cpp: add the program it belongs to";
    }
  }
}

TEST_F(Shaders, CompileErrorNamesFileAndLine) {
  const ShaderSource broken{GL_FRAGMENT_SHADER, "shaders/broken.frag",
                            "#version 310 es\n"
                            "precision highp float;\n"
                            "out vec4 colour;\n"
                            "void main() {\n"
                            "  colour = vec4(undeclared_name);\n"
                            "}\n"};
  try {
    compile_shader(broken);
    FAIL() << "expected ShaderError";
  } catch (const ShaderError& error) {
    const std::string message = error.what();
    EXPECT_NE(message.find("shaders/broken.frag:5: "), std::string::npos) << message;
    EXPECT_NE(message.find("undeclared_name"), std::string::npos) << message;
  }
}

TEST_F(Shaders, LinkErrorIsReported) {
  const ShaderSource vertex{GL_VERTEX_SHADER, "v.vert",
                            "#version 310 es\nvoid main() { gl_Position = vec4(0.0); }\n"};
  const ShaderSource fragment{GL_FRAGMENT_SHADER, "f.frag",
                              "#version 310 es\nprecision highp float;\nin vec3 never_written;\n"
                              "out vec4 colour;\nvoid main() { colour = vec4(never_written, 1.0); }\n"};
  const std::vector<ShaderSource> sources{vertex, fragment};
  try {
    link_program(sources);
    FAIL() << "expected ShaderError";
  } catch (const ShaderError& error) {
    EXPECT_NE(std::string(error.what()).find("v.vert + f.frag does not link"), std::string::npos) << error.what();
  }
}

TEST(ShaderLog, ParsesTheDriversLineNumbers) {
  EXPECT_EQ(format_shader_log("shaders/a.frag", "0:12(5): error: `x' undeclared\n"),
            "shaders/a.frag:12: error: `x' undeclared");
  EXPECT_EQ(format_shader_log("a.frag", "0(7) : error C1008: undefined variable \"x\"\n"),
            "a.frag:7: error C1008: undefined variable \"x\"");
  EXPECT_EQ(format_shader_log("a.frag", "ERROR: 0:3: 'x' : undeclared identifier\nERROR: 1 compilation errors.\n"),
            "a.frag:3: error: 'x' : undeclared identifier\na.frag: ERROR: 1 compilation errors.");
  EXPECT_EQ(format_shader_log("a.frag", ""), "a.frag: (the driver gave no log)");
}

TEST(ShaderDir, ExplicitDirectoryWinsAndMustExist) {
  EXPECT_EQ(find_shader_dir(kShaderDir), kShaderDir);
  EXPECT_THROW(find_shader_dir(kShaderDir / "no-such-folder"), InputError);
}

TEST(ShaderDir, EnvironmentThenDefaults) {
  const char* previous = std::getenv("SKYLIT_SHADER_DIR");
  const std::string saved = previous != nullptr ? previous : "";
  const fs::path elsewhere = fs::temp_directory_path();
  ::setenv("SKYLIT_SHADER_DIR", elsewhere.c_str(), 1);
  const fs::path from_environment = find_shader_dir();
  ::setenv("SKYLIT_SHADER_DIR", (elsewhere / "skylit-no-such-folder").c_str(), 1);
  bool missing_rejected = false;
  try {
    find_shader_dir();
  } catch (const InputError& error) {
    missing_rejected = std::string(error.what()).find("SKYLIT_SHADER_DIR") != std::string::npos;
  }
  ::unsetenv("SKYLIT_SHADER_DIR");
  const fs::path fallback = find_shader_dir();
  if (previous != nullptr) ::setenv("SKYLIT_SHADER_DIR", saved.c_str(), 1);

  EXPECT_EQ(from_environment, elsewhere);
  EXPECT_TRUE(missing_rejected);
  // The test program lives in the build tree's bin/, beside its share/skylit (no source path is
  // compiled in): the copies there are the source tree's shaders.
  EXPECT_EQ(fallback, fs::path(SKYLIT_BINARY_DIR) / "share" / "skylit" / "shaders");
  EXPECT_EQ(read_file(fallback / "visibility.frag"), read_file(kShaderDir / "visibility.frag"));
}

TEST(ShaderDir, MissingShaderFileIsAnInputError) {
  const HeadlessContext context;
  try {
    load_program(kShaderDir, {"no_such_shader.vert", "visibility.frag"});
    FAIL() << "expected InputError";
  } catch (const InputError& error) {
    EXPECT_NE(std::string(error.what()).find("no_such_shader.vert"), std::string::npos) << error.what();
  }
}

}  // namespace
}  // namespace skylit::gpu
