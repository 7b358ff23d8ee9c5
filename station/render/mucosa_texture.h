#pragma once

#include <cstdint>
#include <opencv2/core.hpp>
#include <string>

namespace ves::render {

// A seamless (tileable) image of colonic mucosa, made with OpenCV: pink
// base with soft blotches, fine granularity and branching submucosal
// vessels. Deterministic for a seed. 8-bit BGR, size x size.
cv::Mat MakeProceduralMucosa(int size = 512, std::uint64_t seed = 1);

// Decodes a case's texture image (PNG or JPEG bytes, ColonCase.mucosa_texture)
// into 8-bit BGR; throws std::invalid_argument when it is not an image.
cv::Mat DecodeMucosaTexture(const std::string& encoded);

}  // namespace ves::render
