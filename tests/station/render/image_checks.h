#pragma once

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

// Image measurements shared by the render tests.
namespace ves::render::testing {

inline cv::Mat Grey(const cv::Mat& bgr) {
  cv::Mat grey;
  cv::cvtColor(bgr, grey, cv::COLOR_BGR2GRAY);
  return grey;
}

// Centre of the darkest region: the minimum after a wide blur, so single
// dark pixels (line gaps, texture) do not count.
inline cv::Point2d DarkestRegion(const cv::Mat& bgr, double blur_sigma_px) {
  cv::Mat grey;
  Grey(bgr).convertTo(grey, CV_32F);
  cv::GaussianBlur(grey, grey, cv::Size(0, 0), blur_sigma_px);
  cv::Point location;
  cv::minMaxLoc(grey, nullptr, nullptr, &location);
  return cv::Point2d(location.x + 0.5, location.y + 0.5);
}

// Mean over `mask` of the grey-level variance in 5x5 windows.
inline double MeanLocalVariance(const cv::Mat& bgr, const cv::Mat& mask) {
  cv::Mat grey;
  Grey(bgr).convertTo(grey, CV_32F);
  cv::Mat mean;
  cv::Mat mean_of_squares;
  cv::blur(grey, mean, cv::Size(5, 5));
  cv::blur(grey.mul(grey), mean_of_squares, cv::Size(5, 5));
  const cv::Mat variance = mean_of_squares - mean.mul(mean);
  return cv::mean(variance, mask)[0];
}

// Share of pixels under `mask` with grey level below `level`.
inline double DarkShare(const cv::Mat& bgr, const cv::Mat& mask, int level) {
  const cv::Mat dark = (Grey(bgr) < level) & mask;
  return static_cast<double>(cv::countNonZero(dark)) / cv::countNonZero(mask);
}

// Column span [first, last] of pixels darker than `level` (-1, -1 if none).
inline cv::Vec2i DarkColumnSpan(const cv::Mat& bgr, int level) {
  const cv::Mat dark = Grey(bgr) < level;
  cv::Mat columns;
  cv::reduce(dark, columns, 0, cv::REDUCE_MAX);
  int first = -1;
  int last = -1;
  for (int x = 0; x < columns.cols; ++x) {
    if (columns.at<uchar>(0, x) == 0) continue;
    if (first < 0) first = x;
    last = x;
  }
  return {first, last};
}

}  // namespace ves::render::testing
