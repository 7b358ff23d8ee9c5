#pragma once

#include <Eigen/Core>
#include <memory>
#include <opencv2/core.hpp>
#include <string>

#include "station/render/colon_mesh.h"
#include "station/render/gl_context.h"
#include "station/render/gl_objects_fwd.h"
#include "station/render/scene_geometry.h"

namespace ves::render {

// Paper §4.2: wire frame for beginners (see through the wall), flat polygons
// for intermediates, texture-mapped mucosa for advanced trainees.
enum class EndoscopeMode { kWireframe, kPolygon, kTexture };

// "wireframe", "polygon", "texture"; throws std::invalid_argument otherwise.
EndoscopeMode ParseEndoscopeMode(const std::string& name);
const char* EndoscopeModeName(EndoscopeMode mode);

struct EndoscopeViewOptions {
  int width{640};
  int height{480};
  // Full angle across the image diagonal. Equidistant fisheye (r = f·θ):
  // the barrel distortion of a real colonoscope's wide-angle lens.
  double field_of_view_rad{140.0 * 3.14159265358979323846 / 180.0};
  // The light sits at the lens: full brightness up to this distance, then
  // 1/d² falloff, so the far lumen is dark (the cue doctors steer by).
  double light_reference_distance_m{0.03};
  // Wall closer to the lens than this fills the pixel with red (red-out).
  double red_out_distance_m{0.005};
  ColonMeshOptions mesh;
};

struct EndoscopeFrame {
  cv::Mat image;  // 8-bit BGR, width x height
  // Share of the image where the wall is within red_out_distance_m of the
  // lens (1 when the lens is inside the wall): a per-frame red-out measure.
  double red_out_share{0.0};
  bool lens_in_wall{false};
};

// The endoscope image from the camera at the distal tip (paper §4.2): the
// colon mesh rebuilt from the scene every frame, lit by a light at the
// lens, drawn in one of three modes that may change between any two frames,
// through an equidistant fisheye lens. Needs its GlContext current on the
// calling thread (Render makes it current).
class EndoscopeView {
 public:
  explicit EndoscopeView(GlContext* context, EndoscopeViewOptions options = {});
  ~EndoscopeView();
  EndoscopeView(const EndoscopeView&) = delete;
  EndoscopeView& operator=(const EndoscopeView&) = delete;

  EndoscopeMode mode() const { return mode_; }
  void set_mode(EndoscopeMode mode) { mode_ = mode; }
  const EndoscopeViewOptions& options() const { return options_; }

  // Replaces the procedural mucosa (e.g. with the case's image, 8-bit BGR).
  void SetMucosaTexture(const cv::Mat& bgr);

  // Draws the scene (validated; std::invalid_argument when inconsistent).
  void Render(const SceneGeometry& scene, EndoscopeFrame* frame);
  EndoscopeFrame Render(const SceneGeometry& scene);

  // Pixel (column right, row down, continuous; pixel (0,0) has its centre
  // at (0.5,0.5)) where a point given in the tip frame lands through the
  // fisheye: tip +x is right, tip +y is up.
  Eigen::Vector2d ProjectTipPoint(const Eigen::Vector3d& p_TipPoint) const;
  // The lens's focal length in pixels per radian of view angle.
  double focal_px_per_rad() const;

 private:
  void UploadMesh();
  void BindTriangles();
  void SetCommonUniforms(const GlProgram& program, const Eigen::Isometry3d& X_WTip, int width,
                         int height) const;
  bool LensInWall(const Eigen::Vector3d& p_WTip) const;

  GlContext* context_;
  EndoscopeViewOptions options_;
  EndoscopeMode mode_{EndoscopeMode::kTexture};
  ColonMesh mesh_;
  std::vector<double> arc_m_;
  cv::Mat rgba_;
  std::unique_ptr<GlProgram> polygon_program_;
  std::unique_ptr<GlProgram> texture_program_;
  std::unique_ptr<GlProgram> wire_program_;
  std::unique_ptr<OffscreenTarget> target_;
  std::unique_ptr<GlStreamBuffer> vertices_;
  std::unique_ptr<GlStreamBuffer> triangles_;
  std::unique_ptr<GlStreamBuffer> lines_;
  size_t triangles_uploaded_{0};  // vertex count the uploaded indices were built for
  unsigned int vertex_array_{0};
  unsigned int texture_{0};
};

}  // namespace ves::render
