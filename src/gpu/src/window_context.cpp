// A GLFW window with an OpenGL ES 3.1 context through EGL (see window_context.hpp).
#include "skylit/gpu/window_context.hpp"

#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "skylit/base/error.hpp"
#include "skylit/gpu/gl.hpp"

namespace skylit::gpu {

namespace {

// GLFW's last error on this thread, for the message of a ContextError.
std::string glfw_error() {
  const char* description = nullptr;
  const int code = glfwGetError(&description);
  if (code == GLFW_NO_ERROR) return "no error reported";
  char hex[32];
  std::snprintf(hex, sizeof hex, " (GLFW error 0x%X)", static_cast<unsigned>(code));
  return std::string(description != nullptr ? description : "unknown") + hex;
}

std::string gl_text(GLenum name) {
  const auto* text = reinterpret_cast<const char*>(glGetString(name));
  return text != nullptr ? std::string(text) : std::string();
}

// Starts GLFW on the display; ContextError (with the fix) when there is none.
std::string init_glfw() {
  const char* x11 = std::getenv("DISPLAY");
  const char* wayland = std::getenv("WAYLAND_DISPLAY");
  if ((x11 == nullptr || *x11 == '\0') && (wayland == nullptr || *wayland == '\0')) {
    throw ContextError("window: no display ($DISPLAY and $WAYLAND_DISPLAY are unset). Fix: run on the machine's "
                       "desktop, under xvfb-run, or with --headless (output.window: false)");
  }
  if (glfwInit() != GLFW_TRUE) {
    throw ContextError("window: GLFW cannot start: " + glfw_error() +
                       ". Fix: check $DISPLAY and that the X server accepts this user (xauth), or use --headless");
  }
  return wayland != nullptr && *wayland != '\0' ? "Wayland" : std::string("X11 ") + (x11 ? x11 : "");
}

// GLFW's monitors (glfwInit done), primary first.
std::vector<std::string> glfw_monitor_names() {
  int count = 0;
  GLFWmonitor** monitors = glfwGetMonitors(&count);
  std::vector<std::string> names;
  for (int i = 0; i < count; ++i) {
    const char* name = glfwGetMonitorName(monitors[i]);
    names.emplace_back(name != nullptr ? name : "");
  }
  return names;
}

// The monitor called `name`; InputError listing the monitors present when none is.
GLFWmonitor* find_monitor(const std::string& name) {
  int count = 0;
  GLFWmonitor** monitors = glfwGetMonitors(&count);
  for (int i = 0; i < count; ++i) {
    const char* candidate = glfwGetMonitorName(monitors[i]);
    if (candidate != nullptr && name == candidate) return monitors[i];
  }
  std::string present;
  for (const std::string& n : glfw_monitor_names()) present += (present.empty() ? "'" : ", '") + n + "'";
  throw InputError(std::string("display.monitor: no monitor named '").append(name).append("'; monitors present: ")
                       .append(present.empty() ? std::string("none") : present)
                       .append(". Fix: give one of the monitors present (the HMD must be connected and switched on), "
                               "or leave monitor out for a window"));
}

}  // namespace

std::vector<std::string> monitor_names() {
  init_glfw();
  std::vector<std::string> names = glfw_monitor_names();
  glfwTerminate();
  return names;
}

struct WindowContext::State {
  GLFWwindow* window = nullptr;
  Framebuffer read_framebuffer;
  GLuint attached = 0;  // the texture attached to read_framebuffer
  std::string system;
};

WindowContext::WindowContext(const WindowOptions& options) : state_(std::make_unique<State>()) {
  state_->system = init_glfw();
  glfwDefaultWindowHints();
  glfwWindowHint(GLFW_CLIENT_API, GLFW_OPENGL_ES_API);
  glfwWindowHint(GLFW_CONTEXT_CREATION_API, GLFW_EGL_CONTEXT_API);
  glfwWindowHint(GLFW_CONTEXT_VERSION_MAJOR, 3);
  glfwWindowHint(GLFW_CONTEXT_VERSION_MINOR, 1);
  GLFWmonitor* monitor = options.fullscreen ? glfwGetPrimaryMonitor() : nullptr;
  if (!options.monitor.empty()) {
    try {
      monitor = find_monitor(options.monitor);
    } catch (...) {
      glfwTerminate();
      throw;
    }
  }
  int width = options.width, height = options.height;
  if (monitor != nullptr) {
    if (const GLFWvidmode* mode = glfwGetVideoMode(monitor)) {
      width = mode->width;
      height = mode->height;
    }
  }
  state_->window = glfwCreateWindow(width, height, options.title.c_str(), monitor, nullptr);
  if (state_->window == nullptr) {
    const std::string error = glfw_error();
    glfwTerminate();
    throw ContextError("window: no OpenGL ES 3.1 context through EGL on " + state_->system + ": " + error +
                       ". Fix: install Mesa's EGL (libegl-mesa0) or the GPU's driver, or use --headless");
  }
  glfwMakeContextCurrent(state_->window);
  glfwSwapInterval(options.vsync ? 1 : 0);
  state_->read_framebuffer = make_framebuffer();
}

WindowContext::~WindowContext() {
  if (state_->window != nullptr) {
    glfwMakeContextCurrent(state_->window);
    state_->read_framebuffer.reset();
    glfwDestroyWindow(state_->window);
    glfwTerminate();
  }
}

void WindowContext::make_current() const { glfwMakeContextCurrent(state_->window); }

void WindowContext::present(GLuint texture, int width, int height) {
  draw(texture, width, height);
  swap_buffers();
}

void WindowContext::draw(GLuint texture, int width, int height) {
  State& s = *state_;
  glBindFramebuffer(GL_READ_FRAMEBUFFER, s.read_framebuffer.get());
  if (s.attached != texture) {
    glFramebufferTexture2D(GL_READ_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, texture, 0);
    check_framebuffer_complete(GL_READ_FRAMEBUFFER, "WindowContext::draw");
    s.attached = texture;
  }
  int window_width = 0, window_height = 0;
  glfwGetFramebufferSize(s.window, &window_width, &window_height);
  glBindFramebuffer(GL_DRAW_FRAMEBUFFER, 0);
  glViewport(0, 0, window_width, window_height);
  glClearColor(0, 0, 0, 1);
  glClear(GL_COLOR_BUFFER_BIT);
  // Fit with the aspect ratio kept, centred; texel row 0 (the image's top) goes to the window's
  // top, which is GL's last row: the blit flips y.
  const double scale = std::min(static_cast<double>(window_width) / width, static_cast<double>(window_height) / height);
  const int w = static_cast<int>(width * scale), h = static_cast<int>(height * scale);
  const int x0 = (window_width - w) / 2, y0 = (window_height - h) / 2;
  glBlitFramebuffer(0, 0, width, height, x0, y0 + h, x0 + w, y0, GL_COLOR_BUFFER_BIT, GL_LINEAR);
  glBindFramebuffer(GL_READ_FRAMEBUFFER, 0);
  check_gl_error("WindowContext::draw");
}

void WindowContext::swap_buffers() {
  glfwSwapBuffers(state_->window);
  poll_events();
}

void WindowContext::poll_events() {
  glfwPollEvents();
  if (glfwGetKey(state_->window, GLFW_KEY_ESCAPE) == GLFW_PRESS || glfwGetKey(state_->window, GLFW_KEY_Q) == GLFW_PRESS) {
    glfwSetWindowShouldClose(state_->window, GLFW_TRUE);
  }
}

bool WindowContext::close_requested() const { return glfwWindowShouldClose(state_->window) == GLFW_TRUE; }

int WindowContext::framebuffer_width() const {
  int width = 0, height = 0;
  glfwGetFramebufferSize(state_->window, &width, &height);
  return width;
}

int WindowContext::framebuffer_height() const {
  int width = 0, height = 0;
  glfwGetFramebufferSize(state_->window, &width, &height);
  return height;
}

std::string WindowContext::description() const {
  return "OpenGL ES in a window (" + state_->system + ", EGL): " + gl_text(GL_RENDERER) + ", " + gl_text(GL_VERSION);
}

}  // namespace skylit::gpu
