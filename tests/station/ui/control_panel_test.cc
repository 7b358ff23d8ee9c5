#include "station/ui/control_panel.h"

#include <gtest/gtest.h>

#include <opencv2/core.hpp>

namespace ves::ui {
namespace {

cv::Point CenterOf(PanelAction action) {
  for (const auto& button : PanelButtons()) {
    if (button.action == action) {
      return {button.rect.x + button.rect.width / 2, button.rect.y + button.rect.height / 2};
    }
  }
  ADD_FAILURE() << "no button for action";
  return {};
}

TEST(ControlPanel, EveryButtonIsInsideThePanelAndHitsItsOwnAction) {
  for (const auto& button : PanelButtons()) {
    EXPECT_TRUE(cv::Rect(0, 0, kPanelWidth, kPanelHeight).contains(button.rect.br() - cv::Point(1, 1)))
        << button.label;
    const cv::Point center = CenterOf(button.action);
    ASSERT_TRUE(HitTestPanel(center.x, center.y).has_value());
    EXPECT_EQ(*HitTestPanel(center.x, center.y), button.action) << button.label;
  }
  EXPECT_FALSE(HitTestPanel(kPanelWidth - 1, kPanelHeight - 1).has_value());
}

TEST(ControlPanel, ClicksSwitchModesAndToggles) {
  PanelModel model;
  ControlState state;
  ApplyPanelAction(PanelAction::kWireframe, model, &state);
  EXPECT_EQ(state.view_mode, ViewMode::kWireframe);
  ApplyPanelAction(PanelAction::kToggleFluoroscopy, model, &state);
  EXPECT_TRUE(state.fluoroscopy_visible);
  ApplyPanelAction(PanelAction::kToggleDamage, model, &state);
  EXPECT_TRUE(state.damage_display);
  ApplyPanelAction(PanelAction::kRepeat, model, &state);
  EXPECT_TRUE(state.repeat_requested);
}

TEST(ControlPanel, CaseAndScopeChoiceWrapAround) {
  PanelModel model;
  model.case_names = {"paper-sigmoid", "standard-adult", "redundant-sigmoid"};
  model.scope_names = {"adult"};
  ControlState state;
  ApplyPanelAction(PanelAction::kPreviousCase, model, &state);
  EXPECT_EQ(state.case_choice, 2);
  ApplyPanelAction(PanelAction::kNextCase, model, &state);
  EXPECT_EQ(state.case_choice, 0);
  ApplyPanelAction(PanelAction::kNextScope, model, &state);
  EXPECT_EQ(state.scope_choice, 0);
}

TEST(ControlPanel, ActiveButtonIsDrawnDifferently) {
  PanelModel model;
  ControlState wire;
  wire.view_mode = ViewMode::kWireframe;
  ControlState texture;
  texture.view_mode = ViewMode::kTexture;
  const cv::Mat a = DrawControlPanel(model, wire);
  const cv::Mat b = DrawControlPanel(model, texture);
  ASSERT_EQ(a.size(), cv::Size(kPanelWidth, kPanelHeight));
  const cv::Point wire_button = CenterOf(PanelAction::kWireframe) + cv::Point(40, 10);
  EXPECT_NE(a.at<cv::Vec3b>(wire_button), b.at<cv::Vec3b>(wire_button));
}

TEST(ControlPanel, ForceGaugeGrowsWithForceAndTurnsRedWhenExcessive) {
  PanelModel model;
  model.force_gauge_max_N = 10.0;
  model.excessive_force_N = 5.0;
  const ControlState state;
  const cv::Point probe(10 + 340 / 2 + 20, 245 + 19);  // inside the gauge, right of its middle
  model.base_force_N = 2.0;
  const cv::Vec3b low = DrawControlPanel(model, state).at<cv::Vec3b>(probe);
  model.base_force_N = 8.0;
  const cv::Vec3b high = DrawControlPanel(model, state).at<cv::Vec3b>(probe);
  EXPECT_NE(low, high);
  EXPECT_GT(high[2], high[1]);  // red (BGR) dominates over green above the threshold
}

}  // namespace
}  // namespace ves::ui
