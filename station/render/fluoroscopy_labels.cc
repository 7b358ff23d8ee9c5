#include "station/render/fluoroscopy_labels.h"

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace ves::render {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kDegPerRad = 180.0 / kPi;

// Angle in degrees within (-180, 180].
double Wrap180(double degrees) {
  double a = std::fmod(degrees, 360.0);
  if (a <= -180.0) a += 360.0;
  if (a > 180.0) a -= 360.0;
  return a;
}

// Text readable on any grey: a dark outline under a light fill.
void PutOutlined(cv::Mat* bgr, const std::string& text, cv::Point origin, double scale) {
  const int thickness = std::max(1, static_cast<int>(std::lround(scale * 2.0)));
  cv::putText(*bgr, text, origin, cv::FONT_HERSHEY_SIMPLEX, scale, cv::Scalar(0, 0, 0),
              thickness + 3, cv::LINE_AA);
  cv::putText(*bgr, text, origin, cv::FONT_HERSHEY_SIMPLEX, scale, cv::Scalar(255, 255, 255),
              thickness, cv::LINE_AA);
}

}  // namespace

FluoroscopyLabels CalcFluoroscopyLabels(const FluoroscopyCamera& camera, cv::Size image_size) {
  FluoroscopyLabels labels;
  // Image right in W (FluoroscopyView: the yawed -x; tilt turns about it).
  const double right_x = -std::cos(camera.yaw_rad);
  const double right_y = -std::sin(camera.yaw_rad);
  if (std::abs(right_x) >= std::abs(right_y)) {
    // -x is the patient's left (W: +x toward the patient's right).
    labels.right_edge = right_x < 0.0 ? "L" : "R";
    labels.left_edge = right_x < 0.0 ? "R" : "L";
  } else {
    labels.right_edge = right_y < 0.0 ? "P" : "A";  // +y anterior
    labels.left_edge = right_y < 0.0 ? "A" : "P";
  }
  const double yaw_deg = Wrap180(camera.yaw_rad * kDegPerRad);
  char view[48];
  if (std::abs(yaw_deg) < 10.0) {
    std::snprintf(view, sizeof view, "AP");
  } else if (std::abs(std::abs(yaw_deg) - 90.0) < 10.0) {
    std::snprintf(view, sizeof view, "LAT");
  } else if (std::abs(yaw_deg) > 170.0) {
    std::snprintf(view, sizeof view, "PA");
  } else {
    std::snprintf(view, sizeof view, "OBL %+.0f", yaw_deg);
  }
  labels.view = view;
  const double tilt_deg = camera.pitch_rad * kDegPerRad;
  if (std::abs(tilt_deg) >= 1.0) {
    char tilt[32];
    std::snprintf(tilt, sizeof tilt, " tilt %+.0f", tilt_deg);
    labels.view += tilt;
  }
  // Orthographic: the image height covers field_height_m / zoom.
  const double px_per_m = camera.zoom * image_size.height / camera.field_height_m;
  const double wanted_m = 0.2 * image_size.width / px_per_m;
  double best_m = 0.001;
  for (double decade = 0.001; decade <= 10.0; decade *= 10.0) {
    for (double step : {1.0, 2.0, 5.0}) {
      const double length_m = step * decade;
      if (std::abs(std::log(length_m / wanted_m)) < std::abs(std::log(best_m / wanted_m))) {
        best_m = length_m;
      }
    }
  }
  labels.scale_bar_m = best_m;
  labels.scale_bar_px = best_m * px_per_m;
  return labels;
}

void DrawFluoroscopyLabels(const FluoroscopyLabels& labels, cv::Mat* bgr) {
  if (bgr == nullptr || bgr->empty()) return;
  const double scale = std::max(0.4, bgr->rows / 640.0);
  const int margin = static_cast<int>(std::lround(12 * scale));
  int baseline = 0;
  const cv::Size letter =
      cv::getTextSize("R", cv::FONT_HERSHEY_SIMPLEX, scale, 2, &baseline);
  // The view's name top right: a screen's caption goes top left.
  const cv::Size view_size =
      cv::getTextSize(labels.view, cv::FONT_HERSHEY_SIMPLEX, scale, 2, &baseline);
  PutOutlined(bgr, labels.view, {bgr->cols - margin - view_size.width, margin + letter.height},
              scale);
  const int mid_y = bgr->rows / 2 + letter.height / 2;
  PutOutlined(bgr, labels.left_edge, {margin, mid_y}, scale);
  PutOutlined(bgr, labels.right_edge, {bgr->cols - margin - letter.width, mid_y}, scale);
  // Scale bar: bottom left, its length above it.
  const int bar_px = static_cast<int>(std::lround(labels.scale_bar_px));
  const int bar_y = bgr->rows - margin - static_cast<int>(std::lround(4 * scale));
  const int thickness = std::max(2, static_cast<int>(std::lround(4 * scale)));
  cv::line(*bgr, {margin, bar_y}, {margin + bar_px, bar_y}, cv::Scalar(0, 0, 0), thickness + 2);
  cv::line(*bgr, {margin, bar_y}, {margin + bar_px, bar_y}, cv::Scalar(255, 255, 255), thickness);
  char text[32];
  if (labels.scale_bar_m >= 0.01) {
    std::snprintf(text, sizeof text, "%g cm", labels.scale_bar_m * 100.0);
  } else {
    std::snprintf(text, sizeof text, "%g mm", labels.scale_bar_m * 1000.0);
  }
  PutOutlined(bgr, text, {margin, bar_y - thickness - margin / 2}, 0.8 * scale);
}

FluoroscopyCamera CentreZoomOnTip(const FluoroscopyCamera& framing,
                                  const Eigen::Vector3d& p_WTip_m) {
  FluoroscopyCamera camera = framing;
  const double share = std::clamp(framing.zoom - 1.0, 0.0, 1.0);
  camera.center_m = framing.center_m + share * (p_WTip_m - framing.center_m);
  return camera;
}

}  // namespace ves::render
