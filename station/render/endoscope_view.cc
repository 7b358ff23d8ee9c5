#include "station/render/endoscope_view.h"

#include <GLES3/gl3.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <opencv2/imgproc.hpp>
#include <stdexcept>
#include <string>

#include "station/render/gl_objects.h"
#include "station/render/mucosa_texture.h"

namespace ves::render {
namespace {

// Camera-frame position p_C = R_CW (p_W - p_WC); equidistant fisheye:
// image radius proportional to the angle θ from the optical axis (+z).
// Vertices beyond u_max_theta are pushed past the far plane so triangles
// behind the lens are clipped instead of wrapping across the image.
constexpr char kVertexShader[] = R"(#version 300 es
layout(location = 0) in vec3 a_position;
layout(location = 1) in vec3 a_normal;
layout(location = 2) in vec2 a_uv;
layout(location = 3) in float a_ring;
uniform mat3 u_R_CW;
uniform vec3 u_p_WC;
uniform vec2 u_ndc_per_rad;
uniform float u_far_m;
uniform float u_max_theta;
out vec3 v_p_C;
out vec3 v_n_C;
out vec2 v_uv;
out float v_ring;
void main() {
  vec3 p = u_R_CW * (a_position - u_p_WC);
  v_p_C = p;
  v_n_C = u_R_CW * a_normal;
  v_uv = a_uv;
  v_ring = a_ring;
  float rho = length(p.xy);
  float theta = atan(rho, p.z);
  vec2 dir = rho > 1e-9 ? p.xy / rho : vec2(0.0);
  float depth = clamp(length(p) / u_far_m, 0.0, 1.0) * 2.0 - 1.0;
  // Tip +y is image up; GL's first row read back is the image top, so the
  // image's y axis is flipped once here.
  vec2 ndc = vec2(dir.x, -dir.y) * theta * u_ndc_per_rad;
  gl_Position = vec4(ndc, theta > u_max_theta ? 2.0 : depth, 1.0);
}
)";

// Polygon (flat: face normal from screen derivatives) or texture (smooth
// normals, mucosa image). Lambert + a wet specular glint from the light at
// the lens, 1/d² falloff, red where the wall touches the lens; alpha 0
// marks red-out pixels for counting.
// Compiled twice, with and without TEXTURED: a uniform branch would make
// a CPU rasteriser sample the texture for flat polygons too.
constexpr char kSurfaceShader[] = R"(
precision highp float;
in vec3 v_p_C;
in vec3 v_n_C;
in vec2 v_uv;
in float v_ring;
uniform sampler2D u_texture;
uniform vec3 u_flat_albedo;
uniform float u_light_ref_m;
uniform float u_red_out_m;
out vec4 o_color;
void main() {
  float d = max(length(v_p_C), 1e-6);
  vec3 to_light = -v_p_C / d;
  vec3 n;
  vec3 albedo;
#ifdef TEXTURED
  n = normalize(v_n_C);
  albedo = texture(u_texture, v_uv).rgb;
#else
  n = normalize(cross(dFdx(v_p_C), dFdy(v_p_C)));
  albedo = u_flat_albedo;
#endif
  float lambert = abs(dot(n, to_light));  // either side faces the light
  float falloff = min(1.0, (u_light_ref_m * u_light_ref_m) / (d * d));
  // Wet glint: lambert^64 by squaring (pow is slow on CPU rasterisers).
  float g = lambert * lambert;
  g *= g; g *= g; g *= g; g *= g; g *= g;
  vec3 c = albedo * (0.02 + 1.1 * lambert * falloff) + vec3(0.35 * g * falloff);
  float red = clamp((2.0 * u_red_out_m - d) / u_red_out_m, 0.0, 1.0);
  c = mix(c, vec3(0.75, 0.06, 0.04), red);
  o_color = vec4(c, d < u_red_out_m ? 0.0 : 1.0);
}
)";

// Wireframe: see-through lines; dimmed by the light's falloff but kept
// faintly visible deeper in so beginners see the tube's course.
constexpr char kWireShader[] = R"(#version 300 es
precision highp float;
in vec3 v_p_C;
in vec3 v_n_C;
in vec2 v_uv;
in float v_ring;
uniform float u_light_ref_m;
uniform float u_red_out_m;
out vec4 o_color;
void main() {
  float d = max(length(v_p_C), 1e-6);
  float falloff = min(1.0, (u_light_ref_m * u_light_ref_m) / (d * d));
  float glow = max(falloff, 0.45 * exp(-d / 0.25));
  vec3 c = vec3(0.55, 1.0, 0.65) * glow;
  float red = smoothstep(2.0 * u_red_out_m, u_red_out_m, d);
  c = mix(c, vec3(0.75, 0.06, 0.04), red);
  o_color = vec4(c, d < u_red_out_m ? 0.0 : 1.0);
}
)";

constexpr double kFarPlane_m = 4.0;
constexpr double kMaxDrawAngle_rad = 1.9;  // ~109°: beyond any image corner
const cv::Vec3f kRedOutBgr(0.04f, 0.06f, 0.75f);

}  // namespace

EndoscopeMode ParseEndoscopeMode(const std::string& name) {
  if (name == "wireframe") return EndoscopeMode::kWireframe;
  if (name == "polygon") return EndoscopeMode::kPolygon;
  if (name == "texture") return EndoscopeMode::kTexture;
  throw std::invalid_argument("endoscope mode must be wireframe, polygon or texture, not '" + name +
                              "'");
}

const char* EndoscopeModeName(EndoscopeMode mode) {
  switch (mode) {
    case EndoscopeMode::kWireframe:
      return "wireframe";
    case EndoscopeMode::kPolygon:
      return "polygon";
    case EndoscopeMode::kTexture:
      return "texture";
  }
  return "?";
}

EndoscopeView::EndoscopeView(GlContext* context, EndoscopeViewOptions options)
    : context_(context), options_(options) {
  if (context_ == nullptr) throw std::invalid_argument("EndoscopeView needs a GlContext");
  if (!(options_.field_of_view_rad > 0.1 && options_.field_of_view_rad < 3.1)) {
    throw std::invalid_argument("endoscope field_of_view_rad must be in (0.1, 3.1), not " +
                                std::to_string(options_.field_of_view_rad));
  }
  context_->MakeCurrent();
  target_ = std::make_unique<OffscreenTarget>(options_.width, options_.height);
  polygon_program_ = std::make_unique<GlProgram>(
      kVertexShader, (std::string("#version 300 es\n") + kSurfaceShader).c_str());
  texture_program_ = std::make_unique<GlProgram>(
      kVertexShader,
      (std::string("#version 300 es\n#define TEXTURED 1\n") + kSurfaceShader).c_str());
  wire_program_ = std::make_unique<GlProgram>(kVertexShader, kWireShader);
  vertices_ = std::make_unique<GlStreamBuffer>(GL_ARRAY_BUFFER);
  triangles_ = std::make_unique<GlStreamBuffer>(GL_ELEMENT_ARRAY_BUFFER);
  lines_ = std::make_unique<GlStreamBuffer>(GL_ELEMENT_ARRAY_BUFFER);
  glGenVertexArrays(1, &vertex_array_);
  glBindVertexArray(vertex_array_);
  glBindBuffer(GL_ARRAY_BUFFER, vertices_->id());
  const auto stride = static_cast<GLsizei>(sizeof(ColonVertex));
  glEnableVertexAttribArray(0);
  glVertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, stride,
                        reinterpret_cast<void*>(offsetof(ColonVertex, position_m)));
  glEnableVertexAttribArray(1);
  glVertexAttribPointer(1, 3, GL_FLOAT, GL_FALSE, stride,
                        reinterpret_cast<void*>(offsetof(ColonVertex, normal)));
  glEnableVertexAttribArray(2);
  glVertexAttribPointer(2, 2, GL_FLOAT, GL_FALSE, stride,
                        reinterpret_cast<void*>(offsetof(ColonVertex, uv)));
  glEnableVertexAttribArray(3);
  glVertexAttribPointer(3, 1, GL_FLOAT, GL_FALSE, stride,
                        reinterpret_cast<void*>(offsetof(ColonVertex, ring)));
  glBindVertexArray(0);
  SetMucosaTexture(MakeProceduralMucosa(512, 1));
}

EndoscopeView::~EndoscopeView() {
  context_->MakeCurrent();
  glDeleteVertexArrays(1, &vertex_array_);
  if (texture_ != 0) glDeleteTextures(1, &texture_);
}

void EndoscopeView::SetMucosaTexture(const cv::Mat& bgr) {
  context_->MakeCurrent();
  const GLuint texture = CreateRepeatTexture(bgr);
  if (texture_ != 0) glDeleteTextures(1, &texture_);
  texture_ = texture;
}

double EndoscopeView::focal_px_per_rad() const {
  const double half_diagonal_px = 0.5 * std::hypot(options_.width, options_.height);
  return half_diagonal_px / (0.5 * options_.field_of_view_rad);
}

Eigen::Vector2d EndoscopeView::ProjectTipPoint(const Eigen::Vector3d& p) const {
  const double rho = std::hypot(p.x(), p.y());
  const double theta = std::atan2(rho, p.z());
  const Eigen::Vector2d dir =
      rho > 1e-12 ? Eigen::Vector2d(p.x() / rho, p.y() / rho) : Eigen::Vector2d::Zero();
  return Eigen::Vector2d(0.5 * options_.width + focal_px_per_rad() * theta * dir.x(),
                         0.5 * options_.height - focal_px_per_rad() * theta * dir.y());
}

void EndoscopeView::SetCommonUniforms(const GlProgram& program, const Eigen::Isometry3d& X_WTip,
                                      int width, int height) const {
  const Eigen::Matrix3f R_CW = X_WTip.linear().transpose().cast<float>();
  const Eigen::Vector3f p_WC = X_WTip.translation().cast<float>();
  glUniformMatrix3fv(program.Uniform("u_R_CW"), 1, GL_FALSE, R_CW.data());
  glUniform3fv(program.Uniform("u_p_WC"), 1, p_WC.data());
  // Same lens at any resolution: focal length scales with the image.
  const double f_px = focal_px_per_rad() * width / options_.width;
  glUniform2f(program.Uniform("u_ndc_per_rad"), static_cast<float>(2.0 * f_px / width),
              static_cast<float>(2.0 * f_px / height));
  glUniform1f(program.Uniform("u_far_m"), static_cast<float>(kFarPlane_m));
  glUniform1f(program.Uniform("u_max_theta"), static_cast<float>(kMaxDrawAngle_rad));
}

void EndoscopeView::UploadMesh() {
  vertices_->Upload(mesh_.vertices.data(), mesh_.vertices.size() * sizeof(ColonVertex));
  glBindVertexArray(vertex_array_);
}

void EndoscopeView::BindTriangles() {
  // The topology depends only on the ring and sector counts, i.e. on the
  // vertex count: re-upload the indices only when that changes.
  if (triangles_uploaded_ != mesh_.vertices.size()) {
    triangles_->Upload(mesh_.triangles.data(), mesh_.triangles.size() * sizeof(std::uint32_t));
    triangles_uploaded_ = mesh_.vertices.size();
  }
  glBindBuffer(GL_ELEMENT_ARRAY_BUFFER, triangles_->id());
}

bool EndoscopeView::LensInWall(const Eigen::Vector3d& p_WTip) const {
  // Nearest mesh ring; the lens is in the wall when it lies farther from
  // that ring's axis than the drawn radius (between folds).
  size_t nearest = 0;
  double nearest_distance = std::numeric_limits<double>::infinity();
  for (size_t k = 0; k < mesh_.ring_centers_m.size(); ++k) {
    const double distance = (p_WTip - mesh_.ring_centers_m[k]).squaredNorm();
    if (distance < nearest_distance) {
      nearest_distance = distance;
      nearest = k;
    }
  }
  const Eigen::Vector3d offset = p_WTip - mesh_.ring_centers_m[nearest];
  const Eigen::Vector3d& t = mesh_.ring_tangents[nearest];
  const double radial = (offset - offset.dot(t) * t).norm();
  return radial >= mesh_.ring_radius_m[nearest];
}

EndoscopeFrame EndoscopeView::Render(const SceneGeometry& scene) {
  EndoscopeFrame frame;
  Render(scene, &frame);
  return frame;
}

void EndoscopeView::Render(const SceneGeometry& scene, EndoscopeFrame* frame) {
  ValidateSceneGeometry(scene);
  context_->MakeCurrent();
  CalcMaterialArcs(scene, &arc_m_);
  BuildColonMesh(scene, arc_m_, CalcArcNear(scene, arc_m_, scene.X_WTip.translation()),
                 options_.mesh, &mesh_);

  frame->lens_in_wall = LensInWall(scene.X_WTip.translation());
  target_->Bind();
  glDisable(GL_BLEND);
  glDisable(GL_CULL_FACE);
  if (frame->lens_in_wall) {
    // Lens inside the mucosa: nothing but red, as in a real scope.
    glClearColor(kRedOutBgr[2], kRedOutBgr[1], kRedOutBgr[0], 0.0f);
    glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
  } else {
    glClearColor(0.0f, 0.0f, 0.0f, 1.0f);
    glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
    UploadMesh();
    if (mode_ == EndoscopeMode::kWireframe) {
      glDisable(GL_DEPTH_TEST);  // see through the wall
      glUseProgram(wire_program_->id());
      SetCommonUniforms(*wire_program_, scene.X_WTip, options_.width, options_.height);
      glUniform1f(wire_program_->Uniform("u_light_ref_m"),
                  static_cast<float>(options_.light_reference_distance_m));
      glUniform1f(wire_program_->Uniform("u_red_out_m"),
                  static_cast<float>(options_.red_out_distance_m));
      // Which rings carry loops moves with the window: upload every frame.
      lines_->Upload(mesh_.lines.data(), mesh_.lines.size() * sizeof(std::uint32_t));
      glBindBuffer(GL_ELEMENT_ARRAY_BUFFER, lines_->id());
      glDrawElements(GL_LINES, static_cast<GLsizei>(mesh_.lines.size()), GL_UNSIGNED_INT, nullptr);
    } else {
      glEnable(GL_DEPTH_TEST);
      glDepthFunc(GL_LESS);
      const GlProgram& program =
          mode_ == EndoscopeMode::kTexture ? *texture_program_ : *polygon_program_;
      glUseProgram(program.id());
      SetCommonUniforms(program, scene.X_WTip, options_.width, options_.height);
      glUniform1i(program.Uniform("u_texture"), 0);
      glUniform3f(program.Uniform("u_flat_albedo"), 0.86f, 0.52f, 0.47f);
      glUniform1f(program.Uniform("u_light_ref_m"),
                  static_cast<float>(options_.light_reference_distance_m));
      glUniform1f(program.Uniform("u_red_out_m"), static_cast<float>(options_.red_out_distance_m));
      glActiveTexture(GL_TEXTURE0);
      glBindTexture(GL_TEXTURE_2D, texture_);
      BindTriangles();
      glDrawElements(GL_TRIANGLES, static_cast<GLsizei>(mesh_.triangles.size()), GL_UNSIGNED_INT,
                     nullptr);
    }
    glBindVertexArray(0);
  }
  target_->ReadRgba(&rgba_);
  if (frame->lens_in_wall) {
    frame->red_out_share = 1.0;
  } else {
    cv::Mat alpha;
    cv::extractChannel(rgba_, alpha, 3);
    frame->red_out_share =
        1.0 - static_cast<double>(cv::countNonZero(alpha)) / static_cast<double>(alpha.total());
  }
  cv::cvtColor(rgba_, frame->image, cv::COLOR_RGBA2BGR);
}

}  // namespace ves::render
