// Shader directory search, compilation with readable diagnostics (see shader.hpp).
#include "skylit/gpu/shader.hpp"

#include <cstdlib>
#include <regex>
#include <sstream>
#include <system_error>
#include <vector>

#include "skylit/base/data_dir.hpp"
#include "skylit/base/error.hpp"
#include "skylit/base/files.hpp"

namespace skylit::gpu {

namespace {

namespace fs = std::filesystem;

const char* stage_name(GLenum stage) {
  switch (stage) {
    case GL_VERTEX_SHADER: return "vertex";
    case GL_FRAGMENT_SHADER: return "fragment";
    case GL_COMPUTE_SHADER: return "compute";
    default: return "unknown-stage";
  }
}

bool directory_exists(const fs::path& dir) {
  std::error_code error;
  return fs::is_directory(dir, error);
}

std::string shader_log(GLuint shader) {
  GLint length = 0;
  glGetShaderiv(shader, GL_INFO_LOG_LENGTH, &length);
  std::string log(static_cast<std::size_t>(std::max(length, 1)), '\0');
  GLsizei written = 0;
  glGetShaderInfoLog(shader, static_cast<GLsizei>(log.size()), &written, log.data());
  log.resize(static_cast<std::size_t>(std::max(written, 0)));
  return log;
}

std::string program_log(GLuint program) {
  GLint length = 0;
  glGetProgramiv(program, GL_INFO_LOG_LENGTH, &length);
  std::string log(static_cast<std::size_t>(std::max(length, 1)), '\0');
  GLsizei written = 0;
  glGetProgramInfoLog(program, static_cast<GLsizei>(log.size()), &written, log.data());
  log.resize(static_cast<std::size_t>(std::max(written, 0)));
  return log;
}

}  // namespace

Shader compile_shader(const ShaderSource& source) {
  Shader shader = make_shader(source.stage);
  const char* text = source.text.c_str();
  const auto length = static_cast<GLint>(source.text.size());
  glShaderSource(shader.get(), 1, &text, &length);
  glCompileShader(shader.get());
  GLint compiled = GL_FALSE;
  glGetShaderiv(shader.get(), GL_COMPILE_STATUS, &compiled);
  if (compiled != GL_TRUE) {
    throw ShaderError(std::string(stage_name(source.stage)) + " shader " + source.label +
                      " does not compile:\n" + format_shader_log(source.label, shader_log(shader.get())));
  }
  return shader;
}

fs::path find_shader_dir(const fs::path& explicit_dir) {
  const std::string fix = "point --shader-dir or SKYLIT_SHADER_DIR at the folder holding skylit's "
                          "*.vert/*.frag/*.comp files (share/skylit/shaders beside the programs' bin/, in the "
                          "build tree as when installed)";
  if (!explicit_dir.empty()) {
    if (!directory_exists(explicit_dir)) {
      throw InputError(input_message(explicit_dir, -1, -1, "shader_dir", "no such directory", fix));
    }
    return explicit_dir;
  }
  if (const char* env = std::getenv("SKYLIT_SHADER_DIR"); env != nullptr && *env != '\0') {
    if (!directory_exists(env)) {
      throw InputError(input_message(env, -1, -1, "SKYLIT_SHADER_DIR", "no such directory", fix));
    }
    return env;
  }
  const fs::path installed = data_dir() / "shaders";
  if (directory_exists(installed)) return installed;
  throw InputError(input_message(installed, -1, -1, "shader_dir", "no shader directory here", fix));
}

GLenum shader_stage(const fs::path& file) {
  const std::string extension = file.extension().string();
  if (extension == ".vert") return GL_VERTEX_SHADER;
  if (extension == ".frag") return GL_FRAGMENT_SHADER;
  if (extension == ".comp") return GL_COMPUTE_SHADER;
  throw InputError(input_message(file, -1, -1, "extension", "unknown shader stage '" + extension + "'",
                                 "name shader files *.vert, *.frag or *.comp"));
}

Program link_program(std::span<const ShaderSource> sources) {
  Program program = make_program();
  std::vector<Shader> shaders;
  std::string labels;
  for (const ShaderSource& source : sources) {
    shaders.push_back(compile_shader(source));
    glAttachShader(program.get(), shaders.back().get());
    labels += (labels.empty() ? "" : " + ") + source.label;
  }
  glLinkProgram(program.get());
  GLint linked = GL_FALSE;
  glGetProgramiv(program.get(), GL_LINK_STATUS, &linked);
  if (linked != GL_TRUE) {
    throw ShaderError("program " + labels + " does not link:\n" + program_log(program.get()));
  }
  // The program keeps the compiled code; the shader objects are no longer needed.
  for (const Shader& shader : shaders) glDetachShader(program.get(), shader.get());
  check_gl_error("link_program(" + labels + ")");
  return program;
}

Program load_program(const fs::path& shader_dir, std::initializer_list<fs::path> files) {
  std::vector<ShaderSource> sources;
  for (const fs::path& file : files) {
    const fs::path path = shader_dir / file;
    std::error_code error;
    if (!fs::is_regular_file(path, error)) {
      throw InputError(input_message(path, -1, -1, "shader", "shader file not found",
                                     "point --shader-dir or SKYLIT_SHADER_DIR at a complete copy of "
                                     "skylit's shaders/ folder"));
    }
    sources.push_back({shader_stage(file), path.string(), read_shader(shader_dir, file)});
  }
  return link_program(sources);
}

std::string read_shader(const fs::path& shader_dir, const fs::path& file) {
  std::string text = read_file(shader_dir / file);
  // Libraries go after the shader's own text, so that the driver's line numbers within the
  // shader stay the file's; the shader declares the library functions it calls.
  static const std::regex library_line(R"(^// library: *([A-Za-z0-9_.-]+\.glsl) *\r?$)");
  std::string appended;
  std::istringstream lines(text);
  std::string line;
  while (std::getline(lines, line)) {
    std::smatch match;
    if (!std::regex_match(line, match, library_line)) continue;
    const fs::path library = shader_dir / match[1].str();
    std::error_code error;
    if (!fs::is_regular_file(library, error)) {
      throw InputError(input_message(shader_dir / file, -1, -1, "library",
                                     std::string("shader library ").append(library.string()).append(" not found"),
                                     "point --shader-dir or SKYLIT_SHADER_DIR at a complete copy of skylit's "
                                     "shaders/ folder"));
    }
    appended.append("\n// ---- ").append(match[1].str()).append(" ----\n").append(read_file(library));
  }
  return text + appended;
}

std::string format_shader_log(const std::string& label, const std::string& log) {
  // Source string 0 is the whole file (nothing is prepended), so driver lines are file lines.
  static const std::regex mesa(R"(^\s*\d+:(\d+)\(\d+\):\s*(.*)$)");
  static const std::regex nvidia(R"(^\s*\d+\((\d+)\)\s*:\s*(.*)$)");
  static const std::regex glslang(R"(^\s*(ERROR|WARNING):\s*\d+:(\d+):\s*(.*)$)");
  std::istringstream lines(log);
  std::string line;
  std::string out;
  while (std::getline(lines, line)) {
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.find_first_not_of(" \t") == std::string::npos) continue;
    std::smatch match;
    if (std::regex_match(line, match, mesa) || std::regex_match(line, match, nvidia)) {
      out += label + ":" + match[1].str() + ": " + match[2].str() + "\n";
    } else if (std::regex_match(line, match, glslang)) {
      std::string kind = match[1].str() == "ERROR" ? "error" : "warning";
      out += label + ":" + match[2].str() + ": " + kind + ": " + match[3].str() + "\n";
    } else {
      out += label + ": " + line + "\n";
    }
  }
  if (out.empty()) out = label + ": (the driver gave no log)\n";
  out.pop_back();
  return out;
}

}  // namespace skylit::gpu
