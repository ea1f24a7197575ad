// Headless EGL context for OpenGL ES 3.1 (see egl_context.hpp).
#include "skylit/gpu/egl_context.hpp"

#include <EGL/egl.h>
#include <EGL/eglext.h>
#include <GLES3/gl31.h>

#include <algorithm>
#include <cctype>
#include <map>
#include <mutex>
#include <set>
#include <sstream>
#include <utility>
#include <vector>

namespace skylit::gpu {

namespace {

// EGL 1.5 names, spelled out so that the file also builds against EGL 1.4 headers.
constexpr EGLint kContextMajorVersion = 0x3098;  // EGL_CONTEXT_MAJOR_VERSION(_KHR)
constexpr EGLint kContextMinorVersion = 0x30FB;  // EGL_CONTEXT_MINOR_VERSION(_KHR)

std::string egl_error_name(EGLint code) {
  switch (code) {
    case EGL_SUCCESS: return "EGL_SUCCESS";
    case EGL_NOT_INITIALIZED: return "EGL_NOT_INITIALIZED";
    case EGL_BAD_ACCESS: return "EGL_BAD_ACCESS";
    case EGL_BAD_ALLOC: return "EGL_BAD_ALLOC";
    case EGL_BAD_ATTRIBUTE: return "EGL_BAD_ATTRIBUTE";
    case EGL_BAD_CONTEXT: return "EGL_BAD_CONTEXT";
    case EGL_BAD_CONFIG: return "EGL_BAD_CONFIG";
    case EGL_BAD_CURRENT_SURFACE: return "EGL_BAD_CURRENT_SURFACE";
    case EGL_BAD_DISPLAY: return "EGL_BAD_DISPLAY";
    case EGL_BAD_SURFACE: return "EGL_BAD_SURFACE";
    case EGL_BAD_MATCH: return "EGL_BAD_MATCH";
    case EGL_BAD_PARAMETER: return "EGL_BAD_PARAMETER";
    case EGL_BAD_NATIVE_PIXMAP: return "EGL_BAD_NATIVE_PIXMAP";
    case EGL_BAD_NATIVE_WINDOW: return "EGL_BAD_NATIVE_WINDOW";
    case EGL_CONTEXT_LOST: return "EGL_CONTEXT_LOST";
    default: {
      std::ostringstream text;
      text << "EGL error 0x" << std::hex << code;
      return text.str();
    }
  }
}

std::string last_egl_error() { return egl_error_name(eglGetError()); }

bool has_word(const char* list, std::string_view word) {
  if (list == nullptr) return false;
  std::istringstream words(list);
  std::string item;
  while (words >> item) {
    if (item == word) return true;
  }
  return false;
}

std::string gl_string(GLenum name) {
  const auto* text = reinterpret_cast<const char*>(glGetString(name));
  return text != nullptr ? std::string(text) : std::string();
}

// EGL displays are process-wide: eglGetPlatformDisplay hands every caller the same handle for
// the same device, and one eglTerminate ends it for all of them (EGL_KHR_display_reference,
// which would count users, is missing from Mesa 22). This count mirrors that driver state, so
// that a display is terminated only when the last context on it goes.
class DisplayUsers {
 public:
  static DisplayUsers& instance() {
    static DisplayUsers users;
    return users;
  }

  bool initialize(EGLDisplay display) {
    const std::lock_guard lock(mutex_);
    EGLint major = 0;
    EGLint minor = 0;
    if (eglInitialize(display, &major, &minor) != EGL_TRUE) return false;
    ++users_[display];
    return true;
  }

  void terminate(EGLDisplay display) {
    const std::lock_guard lock(mutex_);
    const auto user = users_.find(display);
    if (user == users_.end()) return;
    if (--user->second > 0) return;
    users_.erase(user);
    eglTerminate(display);
  }

 private:
  std::mutex mutex_;
  std::map<EGLDisplay, int> users_;
};

// A display to try, and how the log names it.
struct Candidate {
  std::string label;
  EGLDisplay display = EGL_NO_DISPLAY;
};

// Devices of EGL_EXT_platform_device, real drivers first, Mesa's software device last.
std::vector<Candidate> device_candidates(const char* client_extensions,
                                         const std::vector<EGLint>& display_attributes,
                                         std::vector<std::string>& failures) {
  std::vector<Candidate> candidates;
  if (!has_word(client_extensions, "EGL_EXT_platform_device")) {
    failures.push_back("EGL device platform: EGL_EXT_platform_device not offered");
    return candidates;
  }
  const auto query_devices =
      reinterpret_cast<PFNEGLQUERYDEVICESEXTPROC>(eglGetProcAddress("eglQueryDevicesEXT"));
  const auto query_device_string =
      reinterpret_cast<PFNEGLQUERYDEVICESTRINGEXTPROC>(eglGetProcAddress("eglQueryDeviceStringEXT"));
  const auto get_platform_display =
      reinterpret_cast<PFNEGLGETPLATFORMDISPLAYEXTPROC>(eglGetProcAddress("eglGetPlatformDisplayEXT"));
  if (query_devices == nullptr || query_device_string == nullptr || get_platform_display == nullptr) {
    failures.push_back("EGL device platform: eglQueryDevicesEXT not available");
    return candidates;
  }
  EGLint count = 0;
  if (query_devices(0, nullptr, &count) != EGL_TRUE || count <= 0) {
    failures.push_back("EGL device platform: no devices (" + last_egl_error() + ")");
    return candidates;
  }
  std::vector<EGLDeviceEXT> devices(static_cast<std::size_t>(count));
  if (query_devices(count, devices.data(), &count) != EGL_TRUE) {
    failures.push_back("EGL device platform: eglQueryDevicesEXT failed (" + last_egl_error() + ")");
    return candidates;
  }
  devices.resize(static_cast<std::size_t>(std::max(count, 0)));
  std::vector<Candidate> software;
  for (std::size_t index = 0; index < devices.size(); ++index) {
    const char* extensions = query_device_string(devices[index], EGL_EXTENSIONS);
    const bool is_software = has_word(extensions, "EGL_MESA_device_software");
    std::string name = "device " + std::to_string(index);
    if (has_word(extensions, "EGL_EXT_device_drm")) {
      const char* file = query_device_string(devices[index], EGL_DRM_DEVICE_FILE_EXT);
      if (file != nullptr) name = file;
    }
    if (is_software) name = "software";
    EGLDisplay display =
        get_platform_display(EGL_PLATFORM_DEVICE_EXT, devices[index], display_attributes.data());
    if (display == EGL_NO_DISPLAY) {
      failures.push_back("EGL device (" + name + "): no display (" + last_egl_error() + ")");
      continue;
    }
    (is_software ? software : candidates).push_back({"EGL device (" + name + ")", display});
  }
  candidates.insert(candidates.end(), software.begin(), software.end());
  return candidates;
}

}  // namespace

struct HeadlessContext::State {
  EGLDisplay display = EGL_NO_DISPLAY;
  EGLContext context = EGL_NO_CONTEXT;
  EGLSurface surface = EGL_NO_SURFACE;
  std::string platform;
  std::vector<std::string> failures;  // platforms tried before the one chosen
  std::string renderer;
  std::string vendor;
  std::string version;
  std::set<std::string, std::less<>> extensions;

  State() = default;
  State(const State&) = delete;
  State& operator=(const State&) = delete;
  ~State() { release(); }

  void release() {
    if (display == EGL_NO_DISPLAY) return;
    if (eglGetCurrentContext() == context) {
      eglMakeCurrent(display, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
    }
    if (surface != EGL_NO_SURFACE) eglDestroySurface(display, surface);
    if (context != EGL_NO_CONTEXT) eglDestroyContext(display, context);
    DisplayUsers::instance().terminate(display);
    display = EGL_NO_DISPLAY;
    context = EGL_NO_CONTEXT;
    surface = EGL_NO_SURFACE;
  }

  // Makes an ES 3.1 context on `display`; on failure says why and leaves nothing behind.
  bool try_display(EGLDisplay candidate, const std::string& label) {
    if (!DisplayUsers::instance().initialize(candidate)) {
      failures.push_back(label + ": eglInitialize failed (" + last_egl_error() + ")");
      return false;
    }
    display = candidate;
    const std::string why = create_context();
    if (why.empty()) {
      platform = label;
      return true;
    }
    failures.push_back(label + ": " + why);
    release();
    return false;
  }

  // Returns "" on success, else the reason.
  std::string create_context() {
    if (eglBindAPI(EGL_OPENGL_ES_API) != EGL_TRUE) {
      return "eglBindAPI(EGL_OPENGL_ES_API) failed (" + last_egl_error() + ")";
    }
    const bool surfaceless =
        has_word(eglQueryString(display, EGL_EXTENSIONS), "EGL_KHR_surfaceless_context");
    // Without surfaceless contexts a 1×1 pbuffer stands in for the (unused) default framebuffer.
    const EGLint config_attributes[] = {EGL_RENDERABLE_TYPE, EGL_OPENGL_ES3_BIT,
                                        EGL_SURFACE_TYPE, surfaceless ? 0 : EGL_PBUFFER_BIT,
                                        EGL_NONE};
    EGLConfig config = nullptr;
    EGLint config_count = 0;
    if (eglChooseConfig(display, config_attributes, &config, 1, &config_count) != EGL_TRUE ||
        config_count < 1) {
      return "no EGL config with EGL_OPENGL_ES3_BIT (" + last_egl_error() + ")";
    }
    const EGLint versioned[] = {kContextMajorVersion, 3, kContextMinorVersion, 1, EGL_NONE};
    context = eglCreateContext(display, config, EGL_NO_CONTEXT, versioned);
    if (context == EGL_NO_CONTEXT) {
      // EGL 1.4 without EGL_KHR_create_context knows only the major version; the GL version is
      // checked below instead.
      const EGLint major_only[] = {EGL_CONTEXT_CLIENT_VERSION, 3, EGL_NONE};
      context = eglCreateContext(display, config, EGL_NO_CONTEXT, major_only);
    }
    if (context == EGL_NO_CONTEXT) {
      return "eglCreateContext for OpenGL ES 3.1 failed (" + last_egl_error() + ")";
    }
    if (!surfaceless) {
      const EGLint pbuffer_attributes[] = {EGL_WIDTH, 1, EGL_HEIGHT, 1, EGL_NONE};
      surface = eglCreatePbufferSurface(display, config, pbuffer_attributes);
      if (surface == EGL_NO_SURFACE) {
        return "no surfaceless contexts and eglCreatePbufferSurface failed (" + last_egl_error() + ")";
      }
    }
    return finish_current();
  }

  // Makes a context in the share group of `share` (current on another thread, or none) on this
  // state's display, with `share`'s config; "" on success, else the reason.
  std::string create_shared_context(EGLContext share) {
    if (eglBindAPI(EGL_OPENGL_ES_API) != EGL_TRUE) {
      return "eglBindAPI(EGL_OPENGL_ES_API) failed (" + last_egl_error() + ")";
    }
    EGLint config_id = 0;
    if (eglQueryContext(display, share, EGL_CONFIG_ID, &config_id) != EGL_TRUE) {
      return "eglQueryContext(EGL_CONFIG_ID) failed (" + last_egl_error() + ")";
    }
    const EGLint config_attributes[] = {EGL_CONFIG_ID, config_id, EGL_NONE};
    EGLConfig config = nullptr;
    EGLint config_count = 0;
    if (eglChooseConfig(display, config_attributes, &config, 1, &config_count) != EGL_TRUE || config_count < 1) {
      return "the shared context's EGL config was not found (" + last_egl_error() + ")";
    }
    const EGLint versioned[] = {kContextMajorVersion, 3, kContextMinorVersion, 1, EGL_NONE};
    context = eglCreateContext(display, config, share, versioned);
    if (context == EGL_NO_CONTEXT) {
      const EGLint major_only[] = {EGL_CONTEXT_CLIENT_VERSION, 3, EGL_NONE};
      context = eglCreateContext(display, config, share, major_only);
    }
    if (context == EGL_NO_CONTEXT) {
      return "eglCreateContext sharing objects failed (" + last_egl_error() + ")";
    }
    if (!has_word(eglQueryString(display, EGL_EXTENSIONS), "EGL_KHR_surfaceless_context")) {
      const EGLint pbuffer_attributes[] = {EGL_WIDTH, 1, EGL_HEIGHT, 1, EGL_NONE};
      surface = eglCreatePbufferSurface(display, config, pbuffer_attributes);
      if (surface == EGL_NO_SURFACE) {
        return "no surfaceless contexts and eglCreatePbufferSurface failed (" + last_egl_error() + ")";
      }
    }
    return finish_current();
  }

  // Makes the new context current and checks its version; "" on success, else the reason.
  std::string finish_current() {
    if (eglMakeCurrent(display, surface, surface, context) != EGL_TRUE) {
      return "eglMakeCurrent failed (" + last_egl_error() + ")";
    }
    GLint gl_major = 0;
    GLint gl_minor = 0;
    glGetIntegerv(GL_MAJOR_VERSION, &gl_major);
    glGetIntegerv(GL_MINOR_VERSION, &gl_minor);
    version = gl_string(GL_VERSION);
    if (gl_major < 3 || (gl_major == 3 && gl_minor < 1)) {
      return "the context is '" + version + "', not OpenGL ES 3.1 or later";
    }
    renderer = gl_string(GL_RENDERER);
    vendor = gl_string(GL_VENDOR);
    GLint extension_count = 0;
    glGetIntegerv(GL_NUM_EXTENSIONS, &extension_count);
    for (GLint i = 0; i < extension_count; ++i) {
      const auto* name = reinterpret_cast<const char*>(glGetStringi(GL_EXTENSIONS, static_cast<GLuint>(i)));
      if (name != nullptr) extensions.emplace(name);
    }
    return {};
  }
};

HeadlessContext::HeadlessContext() : state_(std::make_unique<State>()) {
  State& s = *state_;
  const char* client_extensions = eglQueryString(EGL_NO_DISPLAY, EGL_EXTENSIONS);
  if (client_extensions == nullptr) eglGetError();  // EGL < 1.5 without client extensions
  const std::vector<EGLint> display_attributes{EGL_NONE};

  for (const Candidate& candidate : device_candidates(client_extensions, display_attributes, s.failures)) {
    if (s.try_display(candidate.display, candidate.label)) return;
  }

  const auto get_platform_display =
      reinterpret_cast<PFNEGLGETPLATFORMDISPLAYEXTPROC>(eglGetProcAddress("eglGetPlatformDisplayEXT"));
  if (has_word(client_extensions, "EGL_MESA_platform_surfaceless") && get_platform_display != nullptr) {
    EGLDisplay display = get_platform_display(EGL_PLATFORM_SURFACELESS_MESA, EGL_DEFAULT_DISPLAY,
                                              display_attributes.data());
    if (display == EGL_NO_DISPLAY) {
      s.failures.push_back("Mesa surfaceless: no display (" + last_egl_error() + ")");
    } else if (s.try_display(display, "Mesa surfaceless")) {
      return;
    }
  } else {
    s.failures.push_back("Mesa surfaceless: EGL_MESA_platform_surfaceless not offered");
  }

  EGLDisplay display = eglGetDisplay(EGL_DEFAULT_DISPLAY);
  if (display == EGL_NO_DISPLAY) {
    s.failures.push_back("default display: eglGetDisplay failed (" + last_egl_error() + ")");
  } else if (s.try_display(display, "default display")) {
    return;
  }

  std::string message = "no OpenGL ES 3.1 context could be made through EGL. Tried:";
  for (const std::string& failure : s.failures) message += "\n  - " + failure;
  message +=
      "\nFix: install libegl-mesa0 and libgl1-mesa-dri (Mesa) or a GPU driver; without a display "
      "server set EGL_PLATFORM=surfaceless.";
  throw ContextError(message);
}

HeadlessContext::ShareGroup HeadlessContext::current_share_group() {
  const EGLContext context = eglGetCurrentContext();
  const EGLDisplay display = eglGetCurrentDisplay();
  if (context == EGL_NO_CONTEXT || display == EGL_NO_DISPLAY) {
    throw ContextError("no EGL context is current on this thread to share objects with; fix: make the context "
                       "current (HeadlessContext or WindowContext) before asking for its share group");
  }
  return ShareGroup{display, context};
}

HeadlessContext::HeadlessContext(const ShareGroup& share) : state_(std::make_unique<State>()) {
  State& s = *state_;
  const auto display = static_cast<EGLDisplay>(share.display);
  if (display == EGL_NO_DISPLAY || share.context == nullptr) {
    throw ContextError("a shared context needs a share group (HeadlessContext::current_share_group)");
  }
  // The display is initialised already (its context exists): this counts one more user of it.
  if (!DisplayUsers::instance().initialize(display)) {
    throw ContextError("eglInitialize failed on the shared context's display (" + last_egl_error() + ")");
  }
  s.display = display;
  const std::string why = s.create_shared_context(static_cast<EGLContext>(share.context));
  if (!why.empty()) {
    s.release();
    throw ContextError("no OpenGL ES context sharing objects with the current one: " + why +
                       ". Fix: a driver whose EGL shares contexts on one display (Mesa does)");
  }
  s.platform = "shared with another context";
}

HeadlessContext::~HeadlessContext() = default;
HeadlessContext::HeadlessContext(HeadlessContext&&) noexcept = default;
HeadlessContext& HeadlessContext::operator=(HeadlessContext&&) noexcept = default;

void HeadlessContext::make_current() const {
  if (eglGetCurrentContext() == state_->context) return;
  if (eglMakeCurrent(state_->display, state_->surface, state_->surface, state_->context) != EGL_TRUE) {
    throw ContextError("eglMakeCurrent failed on " + state_->platform + " (" + last_egl_error() +
                       "); a context can be current on one thread at a time");
  }
}

std::string HeadlessContext::renderer() const { return state_->renderer; }
std::string HeadlessContext::vendor() const { return state_->vendor; }
std::string HeadlessContext::version() const { return state_->version; }
std::string HeadlessContext::platform() const { return state_->platform; }

bool HeadlessContext::has_extension(std::string_view name) const {
  return state_->extensions.find(name) != state_->extensions.end();
}

std::string HeadlessContext::description() const {
  std::string text = "OpenGL ES on " + state_->platform + ": " + state_->renderer + " (" +
                     state_->vendor + "), " + state_->version;
  if (!state_->failures.empty()) {
    text += "; tried first:";
    for (const std::string& failure : state_->failures) text += " [" + failure + "]";
  }
  return text;
}

bool is_software_renderer(std::string_view renderer) {
  std::string lower(renderer);
  std::transform(lower.begin(), lower.end(), lower.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  for (const char* name : {"llvmpipe", "softpipe", "swrast", "software rasterizer"}) {
    if (lower.find(name) != std::string::npos) return true;
  }
  return false;
}

}  // namespace skylit::gpu
