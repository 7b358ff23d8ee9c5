#include "station/app/case_preview.h"

#include <algorithm>
#include <opencv2/imgproc.hpp>
#include <string>

#include "patient_db/case_format.h"
#include "station/app/run_views.h"
#include "station/model/model.h"
#include "station/render/fluoroscopy_labels.h"
#include "station/render/fluoroscopy_view.h"
#include "station/render/gl_context.h"
#include "station/render/model_scene.h"
#include "station/training/case_model.h"

namespace ves::station {
namespace {

// The point of the case's centreline polyline at arc length `arc_m`.
Eigen::Vector3d PointAt(const ves::v1::ColonCase& colon_case, const std::vector<double>& arcs_m,
                        double arc_m) {
  const auto at = [&](size_t i) {
    const auto& p = colon_case.centerline(static_cast<int>(i));
    return Eigen::Vector3d(p.x_m(), p.y_m(), p.z_m());
  };
  size_t i = 1;
  while (i + 1 < arcs_m.size() && arcs_m[i] < arc_m) ++i;
  const double span_m = arcs_m[i] - arcs_m[i - 1];
  const double w = span_m > 0.0 ? std::clamp((arc_m - arcs_m[i - 1]) / span_m, 0.0, 1.0) : 0.0;
  return at(i - 1) + w * (at(i) - at(i - 1));
}

}  // namespace

cv::Mat RenderCasePreview(const ves::v1::ColonCase& colon_case, int width, int height) {
  const model::ModelParams params =
      training::MakeModelParams(colon_case, training::DefaultEndoscopeSpec());
  const model::ModelState state = model::MakeInitialState(params);
  const render::SceneGeometry scene = render::SceneFromModel(params, state);
  render::GlContext context;
  render::FluoroscopyOptions options;
  options.width = width;
  options.height = height;
  options.show_scope = false;
  options.noise_level = 0.0;  // a still picture: the same case gives the same image
  render::FluoroscopyView fluoroscopy(&context, options);
  const render::FluoroscopyCamera camera = FrameColon(params, static_cast<double>(width) / height);
  cv::Mat image = fluoroscopy.Render(scene, camera);
  render::DrawFluoroscopyLabels(render::CalcFluoroscopyLabels(camera, image.size()), &image);
  // Each region's name beside a dot at its middle, in yellow: the only colour
  // on the grey X-ray, dark-outlined to read on the colon's shadow too.
  const auto arcs_m = patient_db::CalcControlPointArcs_m(colon_case);
  const cv::Scalar kYellow(0, 230, 255);
  const cv::Scalar kOutline(0, 0, 0);
  const double font_scale = std::max(0.35, height / 1200.0);
  for (const auto& span : colon_case.regions()) {
    const Eigen::Vector3d p_W =
        PointAt(colon_case, arcs_m, 0.5 * (span.start_arc_m() + span.end_arc_m()));
    const Eigen::Vector2d px = fluoroscopy.ProjectPoint(camera, p_W);
    const cv::Point dot(static_cast<int>(px.x()), static_cast<int>(px.y()));
    const cv::Point text = dot + cv::Point(6, 4);
    const std::string name = patient_db::RegionName(span.region());
    cv::circle(image, dot, 4, kOutline, cv::FILLED, cv::LINE_AA);
    cv::circle(image, dot, 3, kYellow, cv::FILLED, cv::LINE_AA);
    cv::putText(image, name, text, cv::FONT_HERSHEY_SIMPLEX, font_scale, kOutline, 3, cv::LINE_AA);
    cv::putText(image, name, text, cv::FONT_HERSHEY_SIMPLEX, font_scale, kYellow, 1, cv::LINE_AA);
  }
  // The anus, where the scope goes in.
  const Eigen::Vector2d anus = fluoroscopy.ProjectPoint(camera, PointAt(colon_case, arcs_m, 0.0));
  const cv::Point anus_px(static_cast<int>(anus.x()), static_cast<int>(anus.y()));
  cv::putText(image, "anus", anus_px + cv::Point(-14, 16), cv::FONT_HERSHEY_SIMPLEX, font_scale,
              kOutline, 3, cv::LINE_AA);
  cv::putText(image, "anus", anus_px + cv::Point(-14, 16), cv::FONT_HERSHEY_SIMPLEX, font_scale,
              kYellow, 1, cv::LINE_AA);
  return image;
}

}  // namespace ves::station
