#pragma once

#include <Eigen/Core>
#include <memory>
#include <opencv2/core.hpp>
#include <vector>

#include "station/render/gl_context.h"
#include "station/render/gl_objects_fwd.h"
#include "station/render/scene_geometry.h"

namespace ves::render {

// Where the X-ray C-arm looks from (paper §4.3: the angle varies
// continuously with the mouse; the image can be enlarged). Orthographic.
// yaw 0, pitch 0 is the AP view: beam from anterior to posterior (along
// -y of W), shown as radiographs are, as if facing the patient: image right
// = -x (the patient's left in the RAS frame W), image up = +z (cranial).
// Yaw turns the C-arm about the patient's long axis z (π/2: lateral, image
// right = -y, posterior), pitch then tilts it about the image's horizontal axis.
struct FluoroscopyCamera {
  double yaw_rad{0.0};
  double pitch_rad{0.0};
  double zoom{1.0};                          // 2 doubles every projected length
  Eigen::Vector2d pan_m{0.0, 0.0};           // view centre moved right/up in the image plane
  Eigen::Vector3d center_m{0.0, 0.0, 0.15};  // point of W at the image centre (zero pan)
  double field_height_m{0.40};               // height of W the image covers at zoom 1
};

struct FluoroscopyOptions {
  int width{640};
  int height{480};
  bool show_colon{true};
  bool show_scope{true};
  // Damage display: rings whose damage_level reaches the threshold are
  // tinted red, deeper red the further over it they are.
  bool damage_display{false};
  double damage_threshold{1.0};
  double ring_spacing_m{0.012};  // one ring drawn per this much colon (Fig. 13)
  int ring_sectors{24};
  int scope_sectors{8};
  // Standard deviation of quantum noise in grey levels, fixed at
  // construction (set 0 there for none; later changes only switch it off).
  double noise_level{3.0};
  double blur_sigma_px{0.7};  // detector blur; 0 for none
};

// The X-ray fluoroscopic image (paper §4.3, Fig. 13): the colon as a
// sequence of rings, the scope as a thick dark tube, X-ray look (dark where
// X-rays are absorbed: subtractive blending on a grey field, so overlaps
// darken), detector blur and noise. Hidden (the X-ray off) gives a black
// frame. Needs its GlContext current on the calling thread.
class FluoroscopyView {
 public:
  explicit FluoroscopyView(GlContext* context, FluoroscopyOptions options = {});
  ~FluoroscopyView();
  FluoroscopyView(const FluoroscopyView&) = delete;
  FluoroscopyView& operator=(const FluoroscopyView&) = delete;

  // Show/hide, colon/scope/damage switches may change between any frames.
  FluoroscopyOptions& options() { return options_; }
  bool visible() const { return visible_; }
  void set_visible(bool visible) { visible_ = visible; }

  // Draws into `bgr` (8-bit BGR, reused). Throws std::invalid_argument for
  // an inconsistent scene or a camera with zoom <= 0.
  void Render(const SceneGeometry& scene, const FluoroscopyCamera& camera, cv::Mat* bgr);
  cv::Mat Render(const SceneGeometry& scene, const FluoroscopyCamera& camera);

  // Pixel (x right, y down) where a point of W lands.
  Eigen::Vector2d ProjectPoint(const FluoroscopyCamera& camera, const Eigen::Vector3d& p_W) const;

 private:
  void BuildColonRings(const SceneGeometry& scene);

  GlContext* context_;
  FluoroscopyOptions options_;
  bool visible_{true};
  std::uint64_t frame_count_{0};
  std::vector<float> ring_vertices_;  // x y z absorption(r g b)
  std::vector<std::uint32_t> ring_lines_;
  std::vector<float> scope_positions_;
  std::vector<std::uint32_t> scope_triangles_;
  cv::Mat rgba_;
  cv::Mat noise_positive_;
  cv::Mat noise_negative_;
  float line_width_px_{1.0f};
  std::unique_ptr<GlProgram> program_;
  std::unique_ptr<OffscreenTarget> target_;
  std::unique_ptr<GlStreamBuffer> ring_vertex_buffer_;
  std::unique_ptr<GlStreamBuffer> ring_index_buffer_;
  std::unique_ptr<GlStreamBuffer> scope_vertex_buffer_;
  std::unique_ptr<GlStreamBuffer> scope_index_buffer_;
  unsigned int ring_array_{0};
  unsigned int scope_array_{0};
};

}  // namespace ves::render
