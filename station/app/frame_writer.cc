#include "station/app/frame_writer.h"

#include <cstdio>
#include <iostream>
#include <stdexcept>
#include <utility>

#include <opencv2/imgcodecs.hpp>

#include "station/app/live_publish.h"
#include "station/app/run_options.h"

namespace ves::station {

void WritePng(const std::filesystem::path& path, const cv::Mat& image) {
  if (!cv::imwrite(path.string(), image)) {
    throw std::runtime_error("cannot write '" + path.string() + "'");
  }
}

FrameWriter::FrameWriter(const training::CaseRun& run, const ves::v1::ColonCase& colon_case,
                         std::filesystem::path dir, double period_s)
    : params_(run.params), dir_(std::move(dir)), period_s_(period_s) {
  try {
    views_.emplace(params_, colon_case);
  } catch (const std::exception& error) {
    std::cerr << kRunName << ": no frames (the views cannot render here: " << error.what()
              << ")\n";
  }
}

void FrameWriter::OnStep(const training::InputSample& input,
                         const training::SessionRunner& runner) {
  if (!views_) return;
  const double t_s = runner.state().time_s;
  if (t_s + 1e-9 < next_frame_s_) return;
  next_frame_s_ += period_s_;
  char name[64];
  std::snprintf(name, sizeof(name), "endoscope_%06.1fs.png", t_s);
  render::FillSceneFromModel(params_, runner.state(), &runner.output(), {}, &scene_);
  WritePng(dir_ / name, views_->Endoscope(scene_, input.view_mode));
  ++frames_;
}

void FrameWriter::Finish(const training::SessionRunner& runner, training::ViewMode mode,
                         bool show_fluoroscopy) {
  if (!views_) return;
  render::FillSceneFromModel(params_, runner.state(), &runner.output(), {}, &scene_);
  WritePng(dir_ / "endoscope_final.png", views_->Endoscope(scene_, mode));
  ++frames_;
  if (!show_fluoroscopy) return;
  FluoroscopyControls controls;
  controls.damage_display = true;
  WritePng(dir_ / "fluoroscopy.png", views_->Fluoroscopy(scene_, controls));
  ++frames_;
}

std::string FrameWriter::EndoscopeJpeg(const training::SessionRunner& runner,
                                       training::ViewMode mode) {
  if (!views_) return {};
  render::FillSceneFromModel(params_, runner.state(), &runner.output(), {}, &scene_);
  return EncodeLiveJpeg(views_->Endoscope(scene_, mode));
}

}  // namespace ves::station
