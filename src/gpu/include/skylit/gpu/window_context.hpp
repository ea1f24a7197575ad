#pragma once
// A window on the display with an OpenGL ES 3.1 context through EGL (GLFW), for the HMD or a
// monitor: the same context kind as HeadlessContext, so every shader and GL object works in both.
// GLFW allows windows on the process's main thread only: make, present and destroy it there.
#include <memory>
#include <string>
#include <vector>

#include <GLES3/gl31.h>

#include "skylit/gpu/egl_context.hpp"

namespace skylit::gpu {

struct WindowOptions {
  int width = 1280;          // the window's size in screen coordinates (the content is scaled to fit)
  int height = 720;
  std::string title = "skylit";
  bool fullscreen = false;   // on the primary monitor, at its current mode (an HMD shown as a monitor)
  // Full screen on the monitor of this name (glfwGetMonitorName: e.g. "HDMI-1", or an HMD's
  // name), at its current mode; empty: as `fullscreen` says. InputError listing the monitors
  // present when none has the name.
  std::string monitor;
  bool vsync = true;         // present() waits for the display's refresh
};

// The names of the monitors of the display ($DISPLAY or $WAYLAND_DISPLAY), primary first.
// ContextError when there is no display.
std::vector<std::string> monitor_names();

class WindowContext {
 public:
  // Opens the window and makes its context current on the calling thread. ContextError (with the
  // fix) when there is no display ($DISPLAY or $WAYLAND_DISPLAY unset, or refused) or no
  // OpenGL ES 3.1 context through EGL on it.
  explicit WindowContext(const WindowOptions& options = {});
  ~WindowContext();
  WindowContext(const WindowContext&) = delete;
  WindowContext& operator=(const WindowContext&) = delete;

  void make_current() const;

  // Shows `texture` (a colour texture of width × height whose texel row 0 is the image's top,
  // e.g. the compositor's display_texture) scaled to fit the window with its aspect ratio kept,
  // swaps buffers and handles the window's events: draw(), then swap_buffers().
  void present(GLuint texture, int width, int height);
  // The two halves of present(): the texture into the back buffer (black bars around it); the
  // back buffer to the screen, and the window's events.
  void draw(GLuint texture, int width, int height);
  void swap_buffers();
  // Handles the window's events without drawing (while there is nothing new to show).
  void poll_events();
  // The user closed the window (or pressed Escape or Q).
  bool close_requested() const;
  // Size of the window's framebuffer in pixels.
  int framebuffer_width() const;
  int framebuffer_height() const;

  // One line for the log: renderer, version, window system.
  std::string description() const;

 private:
  struct State;
  std::unique_ptr<State> state_;
};

}  // namespace skylit::gpu
