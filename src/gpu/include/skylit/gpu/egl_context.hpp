#pragma once
// A headless OpenGL ES 3.1 context through EGL, for the baker, tests and CI: no window, no
// display server. Platforms are tried in order: EGL device (a real GPU driver preferred over a
// software device), Mesa surfaceless, the default display.
#include <memory>
#include <stdexcept>
#include <string>
#include <string_view>

namespace skylit::gpu {

// No OpenGL ES 3.1 context could be made: the message lists the platforms tried, the EGL
// errors met and the fix.
class ContextError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

class HeadlessContext {
 public:
  // Creates the context and makes it current on the calling thread. Throws ContextError.
  HeadlessContext();
  ~HeadlessContext();
  HeadlessContext(HeadlessContext&&) noexcept;
  HeadlessContext& operator=(HeadlessContext&&) noexcept;
  HeadlessContext(const HeadlessContext&) = delete;
  HeadlessContext& operator=(const HeadlessContext&) = delete;

  // Binds the context to the calling thread (GL calls go to the current context).
  void make_current() const;

  std::string renderer() const;  // GL_RENDERER, e.g. "llvmpipe (LLVM 15.0.6, 256 bits)"
  std::string vendor() const;    // GL_VENDOR
  std::string version() const;   // GL_VERSION, e.g. "OpenGL ES 3.2 Mesa 22.3.6"
  std::string platform() const;  // the EGL platform chosen, e.g. "EGL device (/dev/dri/card0)"
  // Whether the GL context offers the extension (e.g. "GL_EXT_color_buffer_float").
  bool has_extension(std::string_view name) const;
  // One line for the caller's log: platform, renderer, version, and what was tried before.
  std::string description() const;

 private:
  struct State;
  std::unique_ptr<State> state_;
};

}  // namespace skylit::gpu
