#pragma once

#include <memory>
#include <opencv2/core.hpp>
#include <string>

#include "station/model/model.h"
#include "station/render/endoscope_view.h"
#include "station/render/fluoroscopy_view.h"
#include "station/render/gl_context.h"
#include "station/render/scene_geometry.h"
#include "station/training/observation.h"
#include "ves/v1/case.pb.h"

// The two views of a running session (paper §4.2, §4.3), offscreen, for the
// headless frames and the interactive windows. One thread uses an instance.
namespace ves::station {

struct FluoroscopyControls {
  double yaw_rad{0.0};
  double pitch_rad{0.0};
  double zoom{1.0};
  bool damage_display{false};
  bool operator==(const FluoroscopyControls&) const = default;
};

class SessionViews {
 public:
  // Creates the GL context and both views for this case (its mucosa texture
  // when it has one). Throws render::RenderError when no EGL/GLES is usable.
  SessionViews(const model::ModelParams& params, const ves::v1::ColonCase& colon_case,
               int width = 640, int height = 480);
  ~SessionViews();

  cv::Mat Endoscope(const render::SceneGeometry& scene, training::ViewMode mode);
  cv::Mat Fluoroscopy(const render::SceneGeometry& scene, const FluoroscopyControls& controls);
  const std::string& renderer() const { return context_->renderer(); }

 private:
  std::unique_ptr<render::GlContext> context_;
  std::unique_ptr<render::EndoscopeView> endoscope_;
  std::unique_ptr<render::FluoroscopyView> fluoroscopy_;
  render::FluoroscopyCamera base_camera_;
};

// The renderer's mode for the view mode a session records (and the UI
// sets): the only translation between the two.
render::EndoscopeMode ToEndoscopeMode(training::ViewMode mode);

// The C-arm framing the whole colon at rest, centred on its bounding box.
render::FluoroscopyCamera FrameColon(const model::ModelParams& params, double aspect);

}  // namespace ves::station
