#include "station/app/run_views.h"

#include <algorithm>

#include "station/render/fluoroscopy_labels.h"
#include "station/render/mucosa_texture.h"

namespace ves::station {

render::FluoroscopyCamera FrameColon(const model::ModelParams& params, double aspect) {
  Eigen::Vector3d low = Eigen::Vector3d::Constant(1e9);
  Eigen::Vector3d high = Eigen::Vector3d::Constant(-1e9);
  double radius_m = 0.0;
  for (const auto& point : params.colon.points) {
    low = low.cwiseMin(point.rest_position_m);
    high = high.cwiseMax(point.rest_position_m);
    radius_m = std::max(radius_m, point.radius_m);
  }
  const Eigen::Vector3d extent = high - low;
  render::FluoroscopyCamera camera;
  camera.center_m = 0.5 * (low + high);
  // Margin for the colon moving and for its radius on every side.
  camera.field_height_m =
      1.15 * std::max(extent.z(), std::max(extent.x(), extent.y()) / aspect) + 4.0 * radius_m;
  return camera;
}

SessionViews::SessionViews(const model::ModelParams& params, const ves::v1::ColonCase& colon_case,
                           int width, int height)
    : context_(std::make_unique<render::GlContext>()) {
  render::EndoscopeViewOptions endoscope_options;
  endoscope_options.width = width;
  endoscope_options.height = height;
  endoscope_ = std::make_unique<render::EndoscopeView>(context_.get(), endoscope_options);
  if (!colon_case.mucosa_texture().image().empty()) {
    endoscope_->SetMucosaTexture(render::DecodeMucosaTexture(colon_case.mucosa_texture().image()));
  }
  render::FluoroscopyOptions fluoroscopy_options;
  fluoroscopy_options.width = width;
  fluoroscopy_options.height = height;
  fluoroscopy_ = std::make_unique<render::FluoroscopyView>(context_.get(), fluoroscopy_options);
  base_camera_ = FrameColon(params, static_cast<double>(width) / height);
}

SessionViews::~SessionViews() = default;

render::EndoscopeMode ToEndoscopeMode(training::ViewMode mode) {
  switch (mode) {
    case training::ViewMode::kWireframe: return render::EndoscopeMode::kWireframe;
    case training::ViewMode::kFlat: return render::EndoscopeMode::kPolygon;
    case training::ViewMode::kTextured: break;
  }
  return render::EndoscopeMode::kTexture;
}

cv::Mat SessionViews::Endoscope(const render::SceneGeometry& scene, training::ViewMode mode) {
  endoscope_->set_mode(ToEndoscopeMode(mode));
  return endoscope_->Render(scene).image;
}

cv::Mat SessionViews::Fluoroscopy(const render::SceneGeometry& scene,
                                  const FluoroscopyControls& controls) {
  render::FluoroscopyCamera camera = base_camera_;
  camera.yaw_rad = controls.yaw_rad;
  camera.pitch_rad = controls.pitch_rad;
  camera.zoom = controls.zoom;
  // Enlarging looks at the scope's tip, not at the middle of the colon.
  camera = render::CentreZoomOnTip(camera, scene.X_WTip.translation());
  fluoroscopy_->options().damage_display = controls.damage_display;
  cv::Mat image = fluoroscopy_->Render(scene, camera);
  render::DrawFluoroscopyLabels(render::CalcFluoroscopyLabels(camera, image.size()), &image);
  return image;
}

}  // namespace ves::station
