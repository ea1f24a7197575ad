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
  // The EGL display and context current on the calling thread (opaque EGL handles), for a
  // context that shares objects with it. ContextError when none is current.
  struct ShareGroup {
    void* display = nullptr;
    void* context = nullptr;
  };
  static ShareGroup current_share_group();

  // Creates the context and makes it current on the calling thread. Throws ContextError.
  HeadlessContext();
  // A context in `share`'s share group (the same display and config; surfaceless where EGL
  // allows), current on the calling thread: textures, buffers, programs and sync objects are
  // common to both, framebuffers and vertex arrays are each context's own. The context `share`
  // names may be current on another thread meanwhile; it must outlive nothing (a share group
  // lives while any of its contexts does). An object changed in one context is safe to use in the
  // other only after the change is complete there (a fence: glFenceSync, then glWaitSync or
  // glClientWaitSync on the other side) and once the user binds it again. Throws ContextError.
  explicit HeadlessContext(const ShareGroup& share);
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

// Whether a GL_RENDERER string names a software rasterizer (Mesa's llvmpipe, softpipe, swrast):
// the baker then ray-traces and the live service blends on the CPU, both faster there.
bool is_software_renderer(std::string_view renderer);

}  // namespace skylit::gpu
