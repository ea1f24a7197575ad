#pragma once
// Shader programs from GLSL ES 3.10 files in the shader directory (shaders/ in the source tree,
// share/skylit/shaders when installed). The stage follows from the extension: .vert, .frag, .comp.
#include <filesystem>
#include <initializer_list>
#include <span>
#include <stdexcept>
#include <string>

#include "skylit/gpu/gl.hpp"

namespace skylit::gpu {

// A shader did not compile or a program did not link. The message has one line per driver
// diagnostic, as "FILE:LINE: message".
class ShaderError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// The directory to load shaders from: `explicit_dir` when given, else $SKYLIT_SHADER_DIR, else
// ../share/skylit/shaders next to the running program, else the source tree's shaders/ (builds
// run from the build tree), else the install prefix's. Throws InputError when an explicit or
// environment directory does not exist, or when no candidate does.
std::filesystem::path find_shader_dir(const std::filesystem::path& explicit_dir = {});

// GL_VERTEX_SHADER, GL_FRAGMENT_SHADER or GL_COMPUTE_SHADER for .vert, .frag, .comp; throws
// InputError otherwise.
GLenum shader_stage(const std::filesystem::path& file);

struct ShaderSource {
  GLenum stage = GL_VERTEX_SHADER;
  std::string label;  // how messages name it, e.g. the file path
  std::string text;   // the complete GLSL, #version line first
};

// Compiles one shader (the context must be current); throws ShaderError with the driver's log.
Shader compile_shader(const ShaderSource& source);

// Compiles and links the sources into a program (the context must be current).
Program link_program(std::span<const ShaderSource> sources);

// Reads shader_dir/file for each file (with its libraries, read_shader) and links them (the
// context must be current). Throws InputError for a missing file, ShaderError for a compile or
// link failure.
Program load_program(const std::filesystem::path& shader_dir,
                     std::initializer_list<std::filesystem::path> files);

// The text of shader_dir/file followed by the text of every shader library it names in a line
// "// library: NAME.glsl" (in shader_dir; GLSL ES has no #include). A library holds functions
// and uniforms shared by several shaders, without a #version line; the shader declares the
// functions it calls (a prototype) before using them. InputError for a missing file.
std::string read_shader(const std::filesystem::path& shader_dir, const std::filesystem::path& file);

// Rewrites a driver's info log as "label:LINE: message" lines. Understands Mesa ("0:12(5): error:
// ..."), NVIDIA ("0(12) : error C0000: ...") and glslang/ANGLE ("ERROR: 0:12: ..."); other
// lines are kept as "label: line".
std::string format_shader_log(const std::string& label, const std::string& log);

}  // namespace skylit::gpu
