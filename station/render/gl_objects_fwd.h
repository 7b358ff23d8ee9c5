#pragma once

// The GL object wrappers of gl_objects.h, declared for the views' headers:
// a view holds them by pointer, so its users need no GL header.
namespace ves::render {

class GlProgram;
class OffscreenTarget;
class GlStreamBuffer;

}  // namespace ves::render
