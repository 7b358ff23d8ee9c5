#pragma once

#include <opencv2/core.hpp>

#include <optional>
#include <string>
#include <vector>

#include "station/ui/controls.h"

namespace ves::ui {

// What the panel shows besides the controls: the force gauge and the live
// metrics of the running session.
struct PanelModel {
  std::vector<std::string> case_names;
  std::vector<std::string> scope_names;
  std::string session_state;        // "running", "finished: cecum reached", ...
  double elapsed_s{0.0};
  double inserted_m{0.0};
  double tip_arc_m{0.0};
  double base_force_N{0.0};
  double force_gauge_max_N{10.0};
  double excessive_force_N{5.0};    // gauge turns red above it
  double pain_s{0.0};
  double loop_s{0.0};
  double xray_s{0.0};
  double redout_fraction{0.0};
};

enum class PanelAction {
  kWireframe, kPolygon, kTexture, kToggleFluoroscopy, kToggleDamage, kRepeat,
  kPreviousCase, kNextCase, kPreviousScope, kNextScope,
};

struct PanelButton {
  PanelAction action;
  cv::Rect rect;
  std::string label;
};

constexpr int kPanelWidth = 360;
constexpr int kPanelHeight = 420;

// Where each button is: fixed, so a click maps to an action without a drawing.
const std::vector<PanelButton>& PanelButtons();

std::optional<PanelAction> HitTestPanel(int x, int y);

// Applies a click; case/scope choice wraps around the panel's lists.
void ApplyPanelAction(PanelAction action, const PanelModel& model, ControlState* state);

// The control window (paper §4.4) as an image: buttons (the active ones
// highlighted), case and scope choice, a force gauge, the live metrics.
cv::Mat DrawControlPanel(const PanelModel& model, const ControlState& state);

}  // namespace ves::ui
