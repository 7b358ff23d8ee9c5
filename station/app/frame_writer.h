#pragma once

#include <filesystem>
#include <optional>
#include <string>

#include <opencv2/core/mat.hpp>

#include "station/app/run_views.h"
#include "station/render/model_scene.h"
#include "station/training/case_run.h"
#include "station/training/session_runner.h"
#include "ves/v1/case.pb.h"

// The PNG output of a headless run (docs/station-run.md, "Frames"): the
// endoscope every so much simulated time, the last endoscope image and the
// fluoroscopy at the end.
namespace ves::station {

// Writes `image` as a PNG file; throws std::runtime_error when it cannot.
void WritePng(const std::filesystem::path& path, const cv::Mat& image);

// Writes endoscope frames every period_s of simulated time and, at the end,
// the last endoscope image and the fluoroscopy with damage display. A
// station without EGL still runs the session: it says so and writes none.
class FrameWriter {
 public:
  FrameWriter(const training::CaseRun& run, const ves::v1::ColonCase& colon_case,
              std::filesystem::path dir, double period_s);

  // Throws std::runtime_error when a frame cannot be written.
  void OnStep(const training::InputSample& input, const training::SessionRunner& runner);
  // A lesson without fluoroscopy renders none (show_fluoroscopy false).
  void Finish(const training::SessionRunner& runner, training::ViewMode mode,
              bool show_fluoroscopy = true);

  int frames() const { return frames_; }

  // The endoscope image now as a small JPEG for live proctoring (320 pixels
  // wide, quality 70); "" when the views cannot render here.
  std::string EndoscopeJpeg(const training::SessionRunner& runner, training::ViewMode mode);

 private:
  const model::ModelParams& params_;
  std::filesystem::path dir_;
  double period_s_;
  double next_frame_s_{0.0};
  std::optional<SessionViews> views_;
  render::SceneGeometry scene_;
  int frames_{0};
};

}  // namespace ves::station
