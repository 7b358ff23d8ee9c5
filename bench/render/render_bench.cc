// Frames per second of each view (paper §4) on a 1000-segment colon, the
// whole frame counted: mesh rebuilt from the rings, drawn, read back into a
// cv::Mat, post-processed. Prints one line per view:
//   view=NAME width=W height=H segments=N fps=F cpu_fps=C
// fps is frames per wall-clock second; cpu_fps is frames per second of this
// process's CPU time (all llvmpipe threads), which stays meaningful when
// other jobs share the machine: on an idle machine fps >= cpu_fps.
// Usage: render_bench [--seconds S] [--segments N] [--width W] [--height H]
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <ctime>
#include <functional>
#include <iostream>
#include <string>

#include "station/render/endoscope_view.h"
#include "station/render/fluoroscopy_view.h"

namespace {

using ves::render::SceneGeometry;
constexpr double kPi = 3.14159265358979323846;

// A colon-like path of about 1.5 m: up the rectum, a sigmoid swing, up the
// descending colon, across, down the ascending colon.
Eigen::Vector3d PathPoint(double s) {
  const double u = s / 1.5;
  return Eigen::Vector3d(0.12 * std::sin(2.0 * kPi * u) + 0.05 * std::sin(9.0 * u),
                         0.04 * std::sin(5.0 * kPi * u), 0.25 * std::sin(kPi * u) + 0.08 * u);
}

SceneGeometry BenchScene(int segments) {
  SceneGeometry scene;
  const double length_m = 1.5;
  for (int i = 0; i < segments; ++i) {
    const double s = length_m * i / (segments - 1);
    const Eigen::Vector3d c = PathPoint(s);
    scene.colon_centers_m.push_back(c);
    scene.colon_tangents.push_back((PathPoint(s + 1e-4) - PathPoint(s - 1e-4)).normalized());
    scene.colon_radius_m.push_back(0.022 + 0.006 * std::sin(7.0 * s));
    scene.wall_deformation_m.push_back(0.0);
    scene.damage_level.push_back(0.5 + 0.8 * std::sin(11.0 * s));
    if (s < 0.6) scene.scope_points_m.push_back(c);
  }
  // Camera on the axis at s = 0.6 m, looking along the tangent.
  const Eigen::Vector3d p = PathPoint(0.6);
  const Eigen::Vector3d z = (PathPoint(0.6 + 1e-4) - PathPoint(0.6 - 1e-4)).normalized();
  const Eigen::Vector3d x = z.cross(Eigen::Vector3d::UnitY()).normalized();
  scene.X_WTip.linear().col(0) = x;
  scene.X_WTip.linear().col(1) = z.cross(x);
  scene.X_WTip.linear().col(2) = z;
  scene.X_WTip.translation() = p;
  return scene;
}

double ProcessCpuSeconds() {
  timespec now{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &now);
  return static_cast<double>(now.tv_sec) + 1e-9 * static_cast<double>(now.tv_nsec);
}

struct Rate {
  double fps;
  double cpu_fps;
};

Rate Measure(double seconds, const std::function<void()>& frame) {
  for (int i = 0; i < 3; ++i) frame();  // warm-up: shaders, buffers
  const auto start = std::chrono::steady_clock::now();
  const double cpu_start = ProcessCpuSeconds();
  int frames = 0;
  double elapsed = 0.0;
  do {
    frame();
    ++frames;
    elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  } while (elapsed < seconds);
  return {frames / elapsed, frames / (ProcessCpuSeconds() - cpu_start)};
}

}  // namespace

int main(int argc, char** argv) {
  double seconds = 3.0;
  int segments = 1000;
  int width = 640;
  int height = 480;
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string flag = argv[i];
    const double value = std::atof(argv[i + 1]);
    if (flag == "--seconds")
      seconds = value;
    else if (flag == "--segments")
      segments = static_cast<int>(value);
    else if (flag == "--width")
      width = static_cast<int>(value);
    else if (flag == "--height")
      height = static_cast<int>(value);
    else {
      std::cerr << "render_bench: unknown option " << flag << "\n";
      return 2;
    }
  }
  try {
    ves::render::GlContext context;
    std::cerr << "renderer: " << context.renderer() << ", " << context.version() << "\n";
    const SceneGeometry scene = BenchScene(segments);
    auto report = [&](const std::string& name, Rate rate) {
      std::cout << "view=" << name << " width=" << width << " height=" << height
                << " segments=" << segments << " fps=" << rate.fps << " cpu_fps=" << rate.cpu_fps
                << std::endl;
    };

    ves::render::EndoscopeViewOptions endoscope_options;
    endoscope_options.width = width;
    endoscope_options.height = height;
    ves::render::EndoscopeView endoscope(&context, endoscope_options);
    ves::render::EndoscopeFrame frame;
    for (auto mode : {ves::render::EndoscopeMode::kWireframe, ves::render::EndoscopeMode::kPolygon,
                      ves::render::EndoscopeMode::kTexture}) {
      endoscope.set_mode(mode);
      report(std::string("endoscope_") + ves::render::EndoscopeModeName(mode),
             Measure(seconds, [&] { endoscope.Render(scene, &frame); }));
    }

    ves::render::FluoroscopyOptions fluoroscopy_options;
    fluoroscopy_options.width = width;
    fluoroscopy_options.height = height;
    fluoroscopy_options.damage_display = true;
    ves::render::FluoroscopyView fluoroscopy(&context, fluoroscopy_options);
    ves::render::FluoroscopyCamera camera;
    cv::Mat image;
    double yaw = 0.0;
    report("fluoroscopy", Measure(seconds, [&] {
             camera.yaw_rad = (yaw += 0.01);  // the C-arm turning, as under the mouse
             fluoroscopy.Render(scene, camera, &image);
           }));
  } catch (const std::exception& error) {
    std::cerr << "render_bench: " << error.what() << "\n";
    return 1;
  }
  return 0;
}
