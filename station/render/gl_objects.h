#pragma once

#include <GLES3/gl3.h>

#include <opencv2/core.hpp>

namespace ves::render {

// A linked GLSL ES 3.00 program. Throws RenderError with the compiler's log
// when a stage does not compile or the program does not link.
class GlProgram {
 public:
  GlProgram(const char* vertex_source, const char* fragment_source);
  ~GlProgram();
  GlProgram(const GlProgram&) = delete;
  GlProgram& operator=(const GlProgram&) = delete;

  GLuint id() const { return id_; }
  GLint Uniform(const char* name) const { return glGetUniformLocation(id_, name); }

 private:
  GLuint id_{0};
};

// An offscreen framebuffer: RGBA8 colour and 24-bit depth renderbuffers.
class OffscreenTarget {
 public:
  OffscreenTarget(int width, int height);
  ~OffscreenTarget();
  OffscreenTarget(const OffscreenTarget&) = delete;
  OffscreenTarget& operator=(const OffscreenTarget&) = delete;

  int width() const { return width_; }
  int height() const { return height_; }
  // Binds the framebuffer and sets the viewport to all of it.
  void Bind() const;
  // Reads the colour buffer into `rgba` (CV_8UC4, reallocated if needed).
  // Row 0 is the framebuffer's bottom row (GL's window coordinates); the
  // views put the image top there by flipping y in their projection.
  void ReadRgba(cv::Mat* rgba) const;

 private:
  int width_;
  int height_;
  GLuint framebuffer_{0};
  GLuint color_{0};
  GLuint depth_{0};
};

// A growable vertex or index buffer, re-filled every frame (GL_STREAM_DRAW).
class GlStreamBuffer {
 public:
  explicit GlStreamBuffer(GLenum target);
  ~GlStreamBuffer();
  GlStreamBuffer(const GlStreamBuffer&) = delete;
  GlStreamBuffer& operator=(const GlStreamBuffer&) = delete;

  GLuint id() const { return id_; }
  // Binds and uploads `bytes` bytes (orphaning the old storage).
  void Upload(const void* data, size_t bytes);

 private:
  GLenum target_;
  GLuint id_{0};
  size_t capacity_{0};
};

// Uploads a BGR image as an RGB texture with mipmaps (bilinear within the
// nearest level: trilinear costs a CPU rasteriser a third more) and GL_REPEAT.
GLuint CreateRepeatTexture(const cv::Mat& bgr);

}  // namespace ves::render
