#include "station/render/gl_context.h"

#include <EGL/egl.h>
#include <EGL/eglext.h>
#include <GLES3/gl3.h>

#include <cstdlib>
#include <cstring>
#include <stdexcept>
#include <vector>

#include "station/render/render_error.h"

namespace ves::render {
namespace {

std::string EglErrorName(EGLint error) {
  switch (error) {
    case EGL_SUCCESS:
      return "EGL_SUCCESS";
    case EGL_NOT_INITIALIZED:
      return "EGL_NOT_INITIALIZED";
    case EGL_BAD_ACCESS:
      return "EGL_BAD_ACCESS";
    case EGL_BAD_ALLOC:
      return "EGL_BAD_ALLOC";
    case EGL_BAD_ATTRIBUTE:
      return "EGL_BAD_ATTRIBUTE";
    case EGL_BAD_CONFIG:
      return "EGL_BAD_CONFIG";
    case EGL_BAD_CONTEXT:
      return "EGL_BAD_CONTEXT";
    case EGL_BAD_DISPLAY:
      return "EGL_BAD_DISPLAY";
    case EGL_BAD_MATCH:
      return "EGL_BAD_MATCH";
    case EGL_BAD_PARAMETER:
      return "EGL_BAD_PARAMETER";
    case EGL_BAD_SURFACE:
      return "EGL_BAD_SURFACE";
    default:
      return "EGL error " + std::to_string(error);
  }
}

bool HasExtension(const char* list, const char* name) {
  if (list == nullptr) return false;
  const size_t length = std::strlen(name);
  for (const char* p = std::strstr(list, name); p != nullptr; p = std::strstr(p + 1, name)) {
    const bool starts = p == list || p[-1] == ' ';
    const bool ends = p[length] == '\0' || p[length] == ' ';
    if (starts && ends) return true;
  }
  return false;
}

// The display for one platform, or EGL_NO_DISPLAY with `why` filled in.
EGLDisplay GetDisplay(EglPlatform platform, int device_index, std::string* why) {
  const char* client_extensions = eglQueryString(EGL_NO_DISPLAY, EGL_EXTENSIONS);
  if (platform == EglPlatform::kDefault) {
    EGLDisplay display = eglGetDisplay(EGL_DEFAULT_DISPLAY);
    if (display == EGL_NO_DISPLAY) *why = "eglGetDisplay(EGL_DEFAULT_DISPLAY) gave no display";
    return display;
  }
  if (client_extensions == nullptr) {
    *why = "no EGL client extensions (no EGL implementation or EGL < 1.5)";
    return EGL_NO_DISPLAY;
  }
  auto get_platform_display = reinterpret_cast<PFNEGLGETPLATFORMDISPLAYEXTPROC>(
      eglGetProcAddress("eglGetPlatformDisplayEXT"));
  if (get_platform_display == nullptr ||
      !HasExtension(client_extensions, "EGL_EXT_platform_base")) {
    *why = "EGL_EXT_platform_base missing";
    return EGL_NO_DISPLAY;
  }
  if (platform == EglPlatform::kSurfaceless) {
    if (!HasExtension(client_extensions, "EGL_MESA_platform_surfaceless")) {
      *why = "EGL_MESA_platform_surfaceless missing";
      return EGL_NO_DISPLAY;
    }
    EGLDisplay display =
        get_platform_display(EGL_PLATFORM_SURFACELESS_MESA, EGL_DEFAULT_DISPLAY, nullptr);
    if (display == EGL_NO_DISPLAY) *why = "surfaceless platform gave no display";
    return display;
  }
  // kDevice
  auto query_devices =
      reinterpret_cast<PFNEGLQUERYDEVICESEXTPROC>(eglGetProcAddress("eglQueryDevicesEXT"));
  if (query_devices == nullptr || !HasExtension(client_extensions, "EGL_EXT_platform_device")) {
    *why = "EGL_EXT_platform_device / eglQueryDevicesEXT missing";
    return EGL_NO_DISPLAY;
  }
  EGLint count = 0;
  std::vector<EGLDeviceEXT> devices(16);
  if (!query_devices(static_cast<EGLint>(devices.size()), devices.data(), &count)) {
    *why = "eglQueryDevicesEXT failed: " + EglErrorName(eglGetError());
    return EGL_NO_DISPLAY;
  }
  if (device_index < 0 || device_index >= count) {
    *why =
        "no EGL device " + std::to_string(device_index) + " (found " + std::to_string(count) + ")";
    return EGL_NO_DISPLAY;
  }
  EGLDisplay display =
      get_platform_display(EGL_PLATFORM_DEVICE_EXT, devices[device_index], nullptr);
  if (display == EGL_NO_DISPLAY) *why = "device platform gave no display";
  return display;
}

}  // namespace

EglPlatform ParseEglPlatform(const std::string& name) {
  if (name == "auto") return EglPlatform::kAuto;
  if (name == "surfaceless") return EglPlatform::kSurfaceless;
  if (name == "device") return EglPlatform::kDevice;
  if (name == "default") return EglPlatform::kDefault;
  throw std::invalid_argument("EGL platform must be auto, surfaceless, device or default, not '" +
                              name + "'");
}

const char* EglPlatformName(EglPlatform platform) {
  switch (platform) {
    case EglPlatform::kAuto:
      return "auto";
    case EglPlatform::kSurfaceless:
      return "surfaceless";
    case EglPlatform::kDevice:
      return "device";
    case EglPlatform::kDefault:
      return "default";
  }
  return "?";
}

GlContext::GlContext(GlContextOptions options) {
  if (const char* env = std::getenv("VES_EGL_PLATFORM"); env != nullptr && *env != '\0') {
    options.platform = ParseEglPlatform(env);
  }
  if (options.platform != EglPlatform::kAuto) {
    Open(options.platform, options);
    return;
  }
  std::string failures;
  for (EglPlatform platform :
       {EglPlatform::kSurfaceless, EglPlatform::kDevice, EglPlatform::kDefault}) {
    try {
      Open(platform, options);
      return;
    } catch (const RenderError& error) {
      failures += std::string(failures.empty() ? "" : "; ") + error.what();
    }
  }
  throw RenderError("no usable EGL/OpenGL ES display: " + failures);
}

GlContext::~GlContext() { Close(); }

void GlContext::Close() {
  auto display = static_cast<EGLDisplay>(display_);
  if (display == EGL_NO_DISPLAY) return;
  eglMakeCurrent(display, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
  if (context_ != nullptr) eglDestroyContext(display, static_cast<EGLContext>(context_));
  if (surface_ != nullptr) eglDestroySurface(display, static_cast<EGLSurface>(surface_));
  // No eglTerminate: the display is shared by every context on this
  // platform, and terminating it would invalidate the other GlContexts.
  display_ = context_ = surface_ = nullptr;
}

void GlContext::Open(EglPlatform platform, const GlContextOptions& options) {
  const std::string where = std::string("EGL platform ") + EglPlatformName(platform) + ": ";
  std::string why;
  EGLDisplay display = GetDisplay(platform, options.device_index, &why);
  if (display == EGL_NO_DISPLAY) throw RenderError(where + "no EGL display (" + why + ")");
  EGLint major = 0;
  EGLint minor = 0;
  if (!eglInitialize(display, &major, &minor)) {
    throw RenderError(where + "eglInitialize failed: " + EglErrorName(eglGetError()));
  }
  display_ = display;
  try {
    if (!eglBindAPI(EGL_OPENGL_ES_API)) throw RenderError(where + "no OpenGL ES API in EGL");
    const bool surfaceless =
        HasExtension(eglQueryString(display, EGL_EXTENSIONS), "EGL_KHR_surfaceless_context");
    const EGLint config_attributes[] = {EGL_RENDERABLE_TYPE,
                                        EGL_OPENGL_ES3_BIT,
                                        EGL_SURFACE_TYPE,
                                        surfaceless ? 0 : EGL_PBUFFER_BIT,
                                        EGL_RED_SIZE,
                                        8,
                                        EGL_GREEN_SIZE,
                                        8,
                                        EGL_BLUE_SIZE,
                                        8,
                                        EGL_NONE};
    EGLConfig config = nullptr;
    EGLint config_count = 0;
    if (!eglChooseConfig(display, config_attributes, &config, 1, &config_count) ||
        config_count < 1) {
      throw RenderError(where + "no EGL config with OpenGL ES 3 (EGL_OPENGL_ES3_BIT)");
    }
    const EGLint context_attributes[] = {EGL_CONTEXT_MAJOR_VERSION, options.gles_major_version,
                                         EGL_CONTEXT_MINOR_VERSION, options.gles_minor_version,
                                         EGL_NONE};
    EGLContext context = eglCreateContext(display, config, EGL_NO_CONTEXT, context_attributes);
    if (context == EGL_NO_CONTEXT) {
      throw RenderError(where + "no OpenGL ES " + std::to_string(options.gles_major_version) + "." +
                        std::to_string(options.gles_minor_version) +
                        " context (eglCreateContext: " + EglErrorName(eglGetError()) + ")");
    }
    context_ = context;
    if (!surfaceless) {
      const EGLint pbuffer_attributes[] = {EGL_WIDTH, 1, EGL_HEIGHT, 1, EGL_NONE};
      EGLSurface surface = eglCreatePbufferSurface(display, config, pbuffer_attributes);
      if (surface == EGL_NO_SURFACE) {
        throw RenderError(where + "no pbuffer surface and no EGL_KHR_surfaceless_context");
      }
      surface_ = surface;
    }
    platform_ = platform;
    MakeCurrent();
  } catch (...) {
    Close();
    throw;
  }
  const auto* renderer = reinterpret_cast<const char*>(glGetString(GL_RENDERER));
  const auto* version = reinterpret_cast<const char*>(glGetString(GL_VERSION));
  renderer_ = renderer != nullptr ? renderer : "";
  version_ = version != nullptr ? version : "";
}

void GlContext::MakeCurrent() {
  auto display = static_cast<EGLDisplay>(display_);
  auto surface = surface_ != nullptr ? static_cast<EGLSurface>(surface_) : EGL_NO_SURFACE;
  if (eglGetCurrentContext() == static_cast<EGLContext>(context_)) return;
  if (!eglMakeCurrent(display, surface, surface, static_cast<EGLContext>(context_))) {
    throw RenderError("eglMakeCurrent failed: " + EglErrorName(eglGetError()));
  }
}

}  // namespace ves::render
