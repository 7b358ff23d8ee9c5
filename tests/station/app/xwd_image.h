#pragma once

// Screenshots taken with `xwd` (X Window Dump) as OpenCV images, for the UI
// tests: the X server's pixels, decoded from the dump's header (size, bits
// per pixel, byte order, colour masks) — an empty image when the dump is
// missing, truncated or of a kind not handled (only TrueColor 24/32 bpp).
#include <opencv2/core.hpp>

#include <string>

namespace ves::station::testing {

cv::Mat DecodeXwd(const std::string& bytes);

}  // namespace ves::station::testing
