#pragma once

#include <stdexcept>
#include <string>

namespace ves::render {

// Thrown when the rendering stack cannot do its job: no EGL display, no
// OpenGL ES 3 context, a shader that does not compile. The message names
// what is missing so a station without a GPU driver says why it has no view.
class RenderError : public std::runtime_error {
 public:
  explicit RenderError(const std::string& what) : std::runtime_error(what) {}
};

}  // namespace ves::render
