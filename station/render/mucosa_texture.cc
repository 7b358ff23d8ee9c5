#include "station/render/mucosa_texture.h"

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <stdexcept>
#include <vector>

namespace ves::render {
namespace {

// Blurs with wrap-around borders so the result stays tileable.
cv::Mat WrapBlur(const cv::Mat& image, double sigma) {
  const int pad = static_cast<int>(3 * sigma) + 1;
  cv::Mat padded;
  cv::copyMakeBorder(image, padded, pad, pad, pad, pad, cv::BORDER_WRAP);
  cv::GaussianBlur(padded, padded, cv::Size(), sigma);
  return padded(cv::Rect(pad, pad, image.cols, image.rows)).clone();
}

// Smooth noise in [-1, 1] with features about size/cells wide, tileable.
cv::Mat TileableNoise(int size, int cells, cv::RNG& rng) {
  cv::Mat coarse(cells, cells, CV_32F);
  rng.fill(coarse, cv::RNG::UNIFORM, -1.0, 1.0);
  cv::Mat tiled;
  cv::repeat(coarse, 3, 3, tiled);
  cv::Mat big;
  cv::resize(tiled, big, cv::Size(3 * size, 3 * size), 0, 0, cv::INTER_CUBIC);
  return big(cv::Rect(size, size, size, size)).clone();
}

// One vessel: a wandering, thinning random walk that sometimes branches.
// Segments are drawn at the nine tile offsets so the image wraps.
void DrawVessel(cv::Mat* mask, cv::Point2d p, double heading, double width, int depth,
                cv::RNG& rng) {
  const int size = mask->cols;
  const int steps = 20 + rng.uniform(0, 30);
  for (int i = 0; i < steps && width > 0.4; ++i) {
    heading += rng.gaussian(0.35);
    const cv::Point2d q = p + cv::Point2d(std::cos(heading), std::sin(heading)) * 6.0;
    for (int dx = -1; dx <= 1; ++dx) {
      for (int dy = -1; dy <= 1; ++dy) {
        const cv::Point2d offset(dx * size, dy * size);
        cv::line(*mask, (p + offset) * 16, (q + offset) * 16, cv::Scalar(255),
                 std::max(1, static_cast<int>(width + 0.5)), cv::LINE_AA, 4);
      }
    }
    p = q;
    if (p.x < 0) p.x += size;
    if (p.y < 0) p.y += size;
    if (p.x >= size) p.x -= size;
    if (p.y >= size) p.y -= size;
    width *= 0.97;
    if (depth < 3 && rng.uniform(0.0, 1.0) < 0.08) {
      DrawVessel(mask, p, heading + (rng.uniform(0, 2) ? 0.8 : -0.8), width * 0.7, depth + 1, rng);
    }
  }
}

}  // namespace

cv::Mat MakeProceduralMucosa(int size, std::uint64_t seed) {
  if (size < 16 || size > 4096) {
    throw std::invalid_argument("mucosa texture size must be 16..4096, not " +
                                std::to_string(size));
  }
  cv::RNG rng(seed);
  // Base colour and soft blotches (BGR): pink-orange mucosa.
  const cv::Vec3f base(120.0f, 135.0f, 225.0f);
  const cv::Mat blotch = TileableNoise(size, 6, rng);
  const cv::Mat grain = TileableNoise(size, size / 6, rng);
  cv::Mat vessels_mask = cv::Mat::zeros(size, size, CV_8U);
  const int vessel_count = 10 + size / 64;
  for (int v = 0; v < vessel_count; ++v) {
    DrawVessel(&vessels_mask,
               cv::Point2d(rng.uniform(0.0, 1.0 * size), rng.uniform(0.0, 1.0 * size)),
               rng.uniform(0.0, 6.283), rng.uniform(1.5, 4.0) * size / 512.0 + 0.8, 0, rng);
  }
  cv::Mat vessels;
  vessels_mask.convertTo(vessels, CV_32F, 1.0 / 255.0);
  vessels = WrapBlur(vessels, 0.8 * size / 512.0 + 0.3);

  cv::Mat image(size, size, CV_8UC3);
  const cv::Vec3f vessel_colour(70.0f, 55.0f, 165.0f);
  for (int y = 0; y < size; ++y) {
    for (int x = 0; x < size; ++x) {
      const float shade = 1.0f + 0.10f * blotch.at<float>(y, x) + 0.05f * grain.at<float>(y, x);
      const float w = std::min(1.0f, vessels.at<float>(y, x) * 0.85f);
      cv::Vec3f colour = base * shade * (1.0f - w) + vessel_colour * w;
      image.at<cv::Vec3b>(y, x) =
          cv::Vec3b(cv::saturate_cast<uchar>(colour[0]), cv::saturate_cast<uchar>(colour[1]),
                    cv::saturate_cast<uchar>(colour[2]));
    }
  }
  return image;
}

cv::Mat DecodeMucosaTexture(const std::string& encoded) {
  const std::vector<uchar> bytes(encoded.begin(), encoded.end());
  cv::Mat image = bytes.empty() ? cv::Mat() : cv::imdecode(bytes, cv::IMREAD_COLOR);
  if (image.empty()) {
    throw std::invalid_argument("mucosa texture (" + std::to_string(encoded.size()) +
                                " bytes) is not a PNG or JPEG image");
  }
  return image;
}

}  // namespace ves::render
