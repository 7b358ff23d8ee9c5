#include "station/ui/control_panel.h"

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cstdio>

namespace ves::ui {
namespace {

const cv::Scalar kBackground(40, 40, 40);
const cv::Scalar kButton(90, 90, 90);
const cv::Scalar kButtonActive(60, 140, 60);
const cv::Scalar kText(235, 235, 235);
const cv::Scalar kGaugeOk(60, 170, 60);
const cv::Scalar kGaugeExcessive(40, 40, 220);

bool IsActive(PanelAction action, const ControlState& state) {
  switch (action) {
    case PanelAction::kWireframe: return state.view_mode == ViewMode::kWireframe;
    case PanelAction::kPolygon: return state.view_mode == ViewMode::kPolygon;
    case PanelAction::kTexture: return state.view_mode == ViewMode::kTexture;
    case PanelAction::kToggleFluoroscopy: return state.fluoroscopy_visible;
    case PanelAction::kToggleDamage: return state.damage_display;
    default: return false;
  }
}

int Wrap(int index, int delta, std::size_t size) {
  if (size == 0) return 0;
  const int n = static_cast<int>(size);
  return ((index + delta) % n + n) % n;
}

std::string NameAt(const std::vector<std::string>& names, int index) {
  return names.empty() ? "-" : names[static_cast<std::size_t>(Wrap(index, 0, names.size()))];
}

void PutText(cv::Mat& image, const std::string& text, cv::Point origin, double scale = 0.5) {
  cv::putText(image, text, origin, cv::FONT_HERSHEY_SIMPLEX, scale, kText, 1, cv::LINE_AA);
}

}  // namespace

const std::vector<PanelButton>& PanelButtons() {
  static const std::vector<PanelButton> kButtons = {
      {PanelAction::kWireframe, {10, 40, 105, 30}, "Wire"},
      {PanelAction::kPolygon, {125, 40, 105, 30}, "Polygon"},
      {PanelAction::kTexture, {240, 40, 110, 30}, "Texture"},
      {PanelAction::kToggleFluoroscopy, {10, 80, 165, 30}, "Fluoroscopy"},
      {PanelAction::kToggleDamage, {185, 80, 165, 30}, "Damage"},
      {PanelAction::kRepeat, {10, 120, 340, 30}, "Repeat training"},
      {PanelAction::kPreviousCase, {10, 160, 30, 30}, "<"},
      {PanelAction::kNextCase, {320, 160, 30, 30}, ">"},
      {PanelAction::kPreviousScope, {10, 200, 30, 30}, "<"},
      {PanelAction::kNextScope, {320, 200, 30, 30}, ">"},
  };
  return kButtons;
}

std::optional<PanelAction> HitTestPanel(int x, int y) {
  for (const auto& button : PanelButtons()) {
    if (button.rect.contains({x, y})) return button.action;
  }
  return std::nullopt;
}

void ApplyPanelAction(PanelAction action, const PanelModel& model, ControlState* state) {
  switch (action) {
    case PanelAction::kWireframe: state->view_mode = ViewMode::kWireframe; break;
    case PanelAction::kPolygon: state->view_mode = ViewMode::kPolygon; break;
    case PanelAction::kTexture: state->view_mode = ViewMode::kTexture; break;
    case PanelAction::kToggleFluoroscopy:
      state->fluoroscopy_visible = !state->fluoroscopy_visible;
      break;
    case PanelAction::kToggleDamage: state->damage_display = !state->damage_display; break;
    case PanelAction::kRepeat: state->repeat_requested = true; break;
    case PanelAction::kPreviousCase:
      state->case_choice = Wrap(state->case_choice, -1, model.case_names.size());
      break;
    case PanelAction::kNextCase:
      state->case_choice = Wrap(state->case_choice, 1, model.case_names.size());
      break;
    case PanelAction::kPreviousScope:
      state->scope_choice = Wrap(state->scope_choice, -1, model.scope_names.size());
      break;
    case PanelAction::kNextScope:
      state->scope_choice = Wrap(state->scope_choice, 1, model.scope_names.size());
      break;
  }
}

cv::Mat DrawControlPanel(const PanelModel& model, const ControlState& state) {
  cv::Mat image(kPanelHeight, kPanelWidth, CV_8UC3, kBackground);
  PutText(image, "VES control", {10, 25}, 0.7);
  for (const auto& button : PanelButtons()) {
    cv::rectangle(image, button.rect, IsActive(button.action, state) ? kButtonActive : kButton,
                  cv::FILLED);
    PutText(image, button.label, {button.rect.x + 8, button.rect.y + 21});
  }
  PutText(image, "case: " + NameAt(model.case_names, state.case_choice), {50, 181});
  PutText(image, "scope: " + NameAt(model.scope_names, state.scope_choice), {50, 221});

  // Force gauge: base thrust force against the device range.
  const cv::Rect gauge(10, 245, 340, 22);
  cv::rectangle(image, gauge, kButton, 1);
  const double share = std::clamp(std::abs(model.base_force_N) / model.force_gauge_max_N, 0.0, 1.0);
  const bool excessive = std::abs(model.base_force_N) > model.excessive_force_N;
  cv::rectangle(image, {gauge.x, gauge.y, static_cast<int>(share * gauge.width), gauge.height},
                excessive ? kGaugeExcessive : kGaugeOk, cv::FILLED);
  char line[128];
  std::snprintf(line, sizeof line, "force %.2f N", model.base_force_N);
  PutText(image, line, {gauge.x + 5, gauge.y + 16});

  const std::string lines[] = {
      "state: " + model.session_state,
      [&] { std::snprintf(line, sizeof line, "time %.1f s   inserted %.0f mm   tip %.0f mm",
                          model.elapsed_s, model.inserted_m * 1e3, model.tip_arc_m * 1e3);
            return std::string(line); }(),
      [&] { std::snprintf(line, sizeof line, "pain %.1f s   loop %.1f s   X-ray %.1f s",
                          model.pain_s, model.loop_s, model.xray_s);
            return std::string(line); }(),
      [&] { std::snprintf(line, sizeof line, "red-out %.0f %%   fluoro zoom %.2fx",
                          model.redout_fraction * 100.0, state.fluoro_zoom);
            return std::string(line); }(),
  };
  int y = 295;
  for (const auto& text : lines) {
    PutText(image, text, {10, y}, 0.45);
    y += 24;
  }
  return image;
}

}  // namespace ves::ui
