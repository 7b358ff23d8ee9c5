#include "station/render/fluoroscopy_view.h"

#include <GLES3/gl3.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>
#include <stdexcept>

#include "station/render/colon_mesh.h"
#include "station/render/gl_objects.h"

namespace ves::render {
namespace {

// Orthographic projection onto the detector plane spanned by right/up.
// Image y is flipped so that glReadPixels' first row is the image top.
constexpr char kVertexShader[] = R"(#version 300 es
layout(location = 0) in vec3 a_position;
layout(location = 1) in vec3 a_absorption;
uniform vec3 u_center;
uniform vec3 u_right;
uniform vec3 u_up;
uniform vec2 u_pan;
uniform vec2 u_ndc_per_m;
out vec3 v_absorption;
void main() {
  vec3 d = a_position - u_center;
  vec2 xy = vec2(dot(d, u_right), dot(d, u_up)) - u_pan;
  gl_Position = vec4(xy.x * u_ndc_per_m.x, -xy.y * u_ndc_per_m.y, 0.0, 1.0);
  v_absorption = a_absorption;
}
)";

// Each layer the beam crosses removes its absorption from the field
// (GL_FUNC_REVERSE_SUBTRACT): overlapping structures add up, like X-rays.
constexpr char kFragmentShader[] = R"(#version 300 es
precision mediump float;
in vec3 v_absorption;
out vec4 o_color;
void main() { o_color = vec4(v_absorption, 0.0); }
)";

constexpr float kFieldGrey = 0.80f;
constexpr float kRingAbsorption = 0.17f;
constexpr float kScopeAbsorption = 0.42f;  // per tube wall; front + back ≈ black
constexpr int kNoiseMargin = 64;

struct CameraAxes {
  Eigen::Vector3d right;
  Eigen::Vector3d up;
};

CameraAxes AxesOf(const FluoroscopyCamera& camera) {
  const Eigen::AngleAxisd yaw(camera.yaw_rad, Eigen::Vector3d::UnitZ());
  const Eigen::Vector3d right = yaw * -Eigen::Vector3d::UnitX();  // patient's left
  const Eigen::AngleAxisd pitch(camera.pitch_rad, right);
  return {right, pitch * Eigen::Vector3d::UnitZ()};
}

void CheckCamera(const FluoroscopyCamera& camera) {
  if (!(camera.zoom > 0.0) || !std::isfinite(camera.zoom)) {
    throw std::invalid_argument("fluoroscopy zoom must be positive, not " +
                                std::to_string(camera.zoom));
  }
  if (!(camera.field_height_m > 0.0)) {
    throw std::invalid_argument("fluoroscopy field_height_m must be positive, not " +
                                std::to_string(camera.field_height_m));
  }
}

}  // namespace

FluoroscopyView::FluoroscopyView(GlContext* context, FluoroscopyOptions options)
    : context_(context), options_(options) {
  if (context_ == nullptr) throw std::invalid_argument("FluoroscopyView needs a GlContext");
  context_->MakeCurrent();
  target_ = std::make_unique<OffscreenTarget>(options_.width, options_.height);
  program_ = std::make_unique<GlProgram>(kVertexShader, kFragmentShader);
  ring_vertex_buffer_ = std::make_unique<GlStreamBuffer>(GL_ARRAY_BUFFER);
  ring_index_buffer_ = std::make_unique<GlStreamBuffer>(GL_ELEMENT_ARRAY_BUFFER);
  scope_vertex_buffer_ = std::make_unique<GlStreamBuffer>(GL_ARRAY_BUFFER);
  scope_index_buffer_ = std::make_unique<GlStreamBuffer>(GL_ELEMENT_ARRAY_BUFFER);

  glGenVertexArrays(1, &ring_array_);
  glBindVertexArray(ring_array_);
  glBindBuffer(GL_ARRAY_BUFFER, ring_vertex_buffer_->id());
  glEnableVertexAttribArray(0);
  glVertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, 6 * sizeof(float), nullptr);
  glEnableVertexAttribArray(1);
  glVertexAttribPointer(1, 3, GL_FLOAT, GL_FALSE, 6 * sizeof(float),
                        reinterpret_cast<void*>(3 * sizeof(float)));
  glGenVertexArrays(1, &scope_array_);
  glBindVertexArray(scope_array_);
  glBindBuffer(GL_ARRAY_BUFFER, scope_vertex_buffer_->id());
  glEnableVertexAttribArray(0);
  glVertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, 3 * sizeof(float), nullptr);
  glDisableVertexAttribArray(1);  // constant absorption (glVertexAttrib3f)
  glBindVertexArray(0);

  // Ring lines about 2 px thick at 480 rows, where the driver allows it.
  GLfloat range[2] = {1.0f, 1.0f};
  glGetFloatv(GL_ALIASED_LINE_WIDTH_RANGE, range);
  line_width_px_ = std::clamp(static_cast<float>(options_.height) / 240.0f, 1.0f, range[1]);

  // Quantum noise, drawn once (seeded) and shifted every frame.
  cv::Mat noise(options_.height + kNoiseMargin, options_.width + kNoiseMargin, CV_32F);
  cv::RNG rng(0x5eed);
  rng.fill(noise, cv::RNG::NORMAL, 0.0, 1.0);
  cv::Mat positive = cv::max(noise, 0.0);
  cv::Mat negative = cv::max(-noise, 0.0);
  cv::Mat channels[3];
  positive.convertTo(channels[0], CV_8U, options_.noise_level);
  channels[1] = channels[0];
  channels[2] = channels[0];
  cv::merge(channels, 3, noise_positive_);
  negative.convertTo(channels[0], CV_8U, options_.noise_level);
  channels[1] = channels[0];
  channels[2] = channels[0];
  cv::merge(channels, 3, noise_negative_);
}

FluoroscopyView::~FluoroscopyView() {
  context_->MakeCurrent();
  glDeleteVertexArrays(1, &ring_array_);
  glDeleteVertexArrays(1, &scope_array_);
}

Eigen::Vector2d FluoroscopyView::ProjectPoint(const FluoroscopyCamera& camera,
                                              const Eigen::Vector3d& p_W) const {
  const CameraAxes axes = AxesOf(camera);
  const Eigen::Vector3d d = p_W - camera.center_m;
  const double px_per_m = camera.zoom * options_.height / camera.field_height_m;
  return Eigen::Vector2d(0.5 * options_.width + (d.dot(axes.right) - camera.pan_m.x()) * px_per_m,
                         0.5 * options_.height - (d.dot(axes.up) - camera.pan_m.y()) * px_per_m);
}

void FluoroscopyView::BuildColonRings(const SceneGeometry& scene) {
  ring_vertices_.clear();
  ring_lines_.clear();
  const size_t n = scene.colon_centers_m.size();
  const int sectors = std::max(3, options_.ring_sectors);
  double since_last_m = 0.0;
  for (size_t i = 0; i < n; ++i) {
    if (i > 0) since_last_m += (scene.colon_centers_m[i] - scene.colon_centers_m[i - 1]).norm();
    if (i > 0 && i + 1 < n && since_last_m < options_.ring_spacing_m) continue;
    since_last_m = 0.0;
    const double deformation = scene.wall_deformation_m.empty() ? 0.0 : scene.wall_deformation_m[i];
    const double radius =
        std::max(scene.colon_radius_m[i] - deformation, 0.15 * scene.colon_radius_m[i]);
    Eigen::Vector3f absorption = Eigen::Vector3f::Constant(kRingAbsorption);
    if (options_.damage_display && !scene.damage_level.empty() &&
        scene.damage_level[i] >= options_.damage_threshold) {
      // Over the threshold: keep red, take green and blue out; more so the
      // further over it (up to twice the threshold).
      const double over =
          std::clamp(scene.damage_level[i] / options_.damage_threshold - 1.0, 0.0, 1.0);
      const auto strength = static_cast<float>(0.35 + 0.3 * over);
      absorption = Eigen::Vector3f(0.02f, strength, strength);
    }
    const Eigen::Vector3d t = scene.colon_tangents[i].normalized();
    const Eigen::Vector3d a = AnyPerpendicular(t);
    const Eigen::Vector3d b = t.cross(a);
    const auto base = static_cast<std::uint32_t>(ring_vertices_.size() / 6);
    for (int j = 0; j < sectors; ++j) {
      const double angle = 2.0 * 3.14159265358979323846 * j / sectors;
      const Eigen::Vector3d p =
          scene.colon_centers_m[i] + radius * (std::cos(angle) * a + std::sin(angle) * b);
      ring_vertices_.insert(
          ring_vertices_.end(),
          {static_cast<float>(p.x()), static_cast<float>(p.y()), static_cast<float>(p.z()),
           absorption.x(), absorption.y(), absorption.z()});
      ring_lines_.insert(ring_lines_.end(), {base + j, base + (j + 1) % sectors});
    }
  }
}

cv::Mat FluoroscopyView::Render(const SceneGeometry& scene, const FluoroscopyCamera& camera) {
  cv::Mat bgr;
  Render(scene, camera, &bgr);
  return bgr;
}

void FluoroscopyView::Render(const SceneGeometry& scene, const FluoroscopyCamera& camera,
                             cv::Mat* bgr) {
  ValidateSceneGeometry(scene);
  CheckCamera(camera);
  ++frame_count_;
  if (!visible_) {
    bgr->create(options_.height, options_.width, CV_8UC3);
    bgr->setTo(cv::Scalar::all(0));
    return;
  }
  context_->MakeCurrent();
  target_->Bind();
  glDisable(GL_DEPTH_TEST);
  glDisable(GL_CULL_FACE);
  glClearColor(kFieldGrey, kFieldGrey, kFieldGrey, 1.0f);
  glClear(GL_COLOR_BUFFER_BIT);
  glEnable(GL_BLEND);
  glBlendEquation(GL_FUNC_REVERSE_SUBTRACT);
  glBlendFunc(GL_ONE, GL_ONE);

  glUseProgram(program_->id());
  const CameraAxes axes = AxesOf(camera);
  const Eigen::Vector3f center = camera.center_m.cast<float>();
  const Eigen::Vector3f right = axes.right.cast<float>();
  const Eigen::Vector3f up = axes.up.cast<float>();
  glUniform3fv(program_->Uniform("u_center"), 1, center.data());
  glUniform3fv(program_->Uniform("u_right"), 1, right.data());
  glUniform3fv(program_->Uniform("u_up"), 1, up.data());
  glUniform2f(program_->Uniform("u_pan"), static_cast<float>(camera.pan_m.x()),
              static_cast<float>(camera.pan_m.y()));
  const double aspect = static_cast<double>(options_.width) / options_.height;
  glUniform2f(program_->Uniform("u_ndc_per_m"),
              static_cast<float>(2.0 * camera.zoom / (camera.field_height_m * aspect)),
              static_cast<float>(2.0 * camera.zoom / camera.field_height_m));

  if (options_.show_colon) {
    BuildColonRings(scene);
    glBindVertexArray(ring_array_);
    ring_vertex_buffer_->Upload(ring_vertices_.data(), ring_vertices_.size() * sizeof(float));
    ring_index_buffer_->Upload(ring_lines_.data(), ring_lines_.size() * sizeof(std::uint32_t));
    glLineWidth(line_width_px_);
    glDrawElements(GL_LINES, static_cast<GLsizei>(ring_lines_.size()), GL_UNSIGNED_INT, nullptr);
  }
  if (options_.show_scope && scene.scope_points_m.size() >= 2) {
    BuildTubeMesh(scene.scope_points_m, 0.5 * scene.scope_diameter_m, options_.scope_sectors,
                  &scope_positions_, &scope_triangles_);
    glBindVertexArray(scope_array_);
    glVertexAttrib3f(1, kScopeAbsorption, kScopeAbsorption, kScopeAbsorption);
    scope_vertex_buffer_->Upload(scope_positions_.data(), scope_positions_.size() * sizeof(float));
    scope_index_buffer_->Upload(scope_triangles_.data(),
                                scope_triangles_.size() * sizeof(std::uint32_t));
    glDrawElements(GL_TRIANGLES, static_cast<GLsizei>(scope_triangles_.size()), GL_UNSIGNED_INT,
                   nullptr);
  }
  glBindVertexArray(0);
  glDisable(GL_BLEND);
  glBlendEquation(GL_FUNC_ADD);

  target_->ReadRgba(&rgba_);
  cv::cvtColor(rgba_, *bgr, cv::COLOR_RGBA2BGR);
  if (options_.blur_sigma_px > 0.0) {
    cv::GaussianBlur(*bgr, *bgr, cv::Size(0, 0), options_.blur_sigma_px);
  }
  if (options_.noise_level > 0.0) {
    const int dx = static_cast<int>((frame_count_ * 37) % kNoiseMargin);
    const int dy = static_cast<int>((frame_count_ * 23) % kNoiseMargin);
    const cv::Rect window(dx, dy, options_.width, options_.height);
    cv::add(*bgr, noise_positive_(window), *bgr);
    cv::subtract(*bgr, noise_negative_(window), *bgr);
  }
}

}  // namespace ves::render
