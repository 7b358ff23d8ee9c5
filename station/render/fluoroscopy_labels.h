#pragma once

// What a radiograph carries besides the image: the view's name (AP, LAT,
// PA, or the oblique angle), the patient's side at each edge (R/L for
// frontal views, A/P for lateral ones) and a scale bar. Drawn onto a
// rendered fluoroscopy image (FluoroscopyView) with OpenCV; the geometry is
// pure and tested apart.
#include <opencv2/core.hpp>
#include <string>

#include "station/render/fluoroscopy_view.h"

namespace ves::render {

struct FluoroscopyLabels {
  std::string view;        // "AP", "LAT", "PA", "OBL 35", with " tilt +20" when tilted
  std::string left_edge;   // the patient's side at the image's left edge: "R", "L", "A" or "P"
  std::string right_edge;
  double scale_bar_m{0.0};   // a round length: 1, 2, 5 or 10 cm ...
  double scale_bar_px{0.0};  // its length in the image
};

// From where the C-arm looks (image right and up as FluoroscopyView draws
// them) and the image height: the bar is the round length nearest a fifth
// of the image width.
FluoroscopyLabels CalcFluoroscopyLabels(const FluoroscopyCamera& camera, cv::Size image_size);

// Draws the labels onto `bgr` (8-bit BGR): the view's name top left, the
// side letters at mid height of the left and right edges, the scale bar
// with its length bottom left.
void DrawFluoroscopyLabels(const FluoroscopyLabels& labels, cv::Mat* bgr);

// The camera centred between the colon's framing and the tip: at zoom 1 the
// whole colon (`framing`), from zoom 2 on the tip at the image centre, a
// blend between; so enlarging looks at the scope's tip.
FluoroscopyCamera CentreZoomOnTip(const FluoroscopyCamera& framing,
                                  const Eigen::Vector3d& p_WTip_m);

}  // namespace ves::render
