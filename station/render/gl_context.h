#pragma once

#include <string>

namespace ves::render {

// Which EGL platform opens the display. kAuto tries surfaceless (Mesa:
// llvmpipe on CPU-only machines), then the EGL device platform (a GPU
// without a window system), then the default display with a pbuffer.
enum class EglPlatform { kAuto, kSurfaceless, kDevice, kDefault };

struct GlContextOptions {
  EglPlatform platform{EglPlatform::kAuto};
  int device_index{0};  // for kDevice: which of eglQueryDevicesEXT's devices
  int gles_major_version{3};
  int gles_minor_version{0};
};

// Parses "auto", "surfaceless", "device" or "default"; throws
// std::invalid_argument naming any other value.
EglPlatform ParseEglPlatform(const std::string& name);
const char* EglPlatformName(EglPlatform platform);

// An OpenGL ES 3 context without a window (EGL, offscreen). Every render
// target is an FBO, so no EGL surface is needed (a 1x1 pbuffer stands in
// where EGL_KHR_surfaceless_context is missing). The environment variable
// VES_EGL_PLATFORM overrides options.platform. Construction makes the
// context current on the calling thread; rendering must stay on that thread.
// Throws RenderError naming what is missing (display, ES3 config, context).
class GlContext {
 public:
  explicit GlContext(GlContextOptions options = {});
  ~GlContext();
  GlContext(const GlContext&) = delete;
  GlContext& operator=(const GlContext&) = delete;

  void MakeCurrent();
  EglPlatform platform() const { return platform_; }
  // GL_RENDERER and GL_VERSION, e.g. "llvmpipe (LLVM 15, 256 bits)".
  const std::string& renderer() const { return renderer_; }
  const std::string& version() const { return version_; }

 private:
  void Open(EglPlatform platform, const GlContextOptions& options);
  void Close();

  void* display_{nullptr};
  void* context_{nullptr};
  void* surface_{nullptr};
  EglPlatform platform_{EglPlatform::kAuto};
  std::string renderer_;
  std::string version_;
};

}  // namespace ves::render
