// The training screen without a display: the layout fits the common screen
// sizes, every button hits its own action, each part is drawn in its own
// area, text shrinks rather than being cut.
#include "station/ui/training_screen.h"

#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>

namespace ves::ui {
namespace {

const cv::Size kScreens[] = {{1920, 1080}, {1366, 768}, {1600, 1000}, {1280, 1024}};

cv::Point CenterOf(const cv::Rect& rect) {
  return {rect.x + rect.width / 2, rect.y + rect.height / 2};
}

const PanelButton& ButtonFor(const ScreenLayout& layout, PanelAction action) {
  for (const auto& button : layout.buttons) {
    if (button.action == action) return button;
  }
  ADD_FAILURE() << "no button for action";
  return layout.buttons.front();
}

bool Inside(const cv::Rect& outer, const cv::Rect& inner) { return (outer & inner) == inner; }

TEST(ScreenLayout, EveryPartIsOnScreenAndNothingOverlaps) {
  for (const cv::Size& screen : kScreens) {
    SCOPED_TRACE(std::to_string(screen.width) + "x" + std::to_string(screen.height));
    const ScreenLayout layout = MakeScreenLayout(screen);
    const cv::Rect canvas({0, 0}, screen);
    const cv::Rect parts[] = {layout.endoscope, layout.fluoroscopy, layout.status, layout.panel};
    for (const cv::Rect& part : parts) {
      EXPECT_TRUE(Inside(canvas, part)) << part;
      EXPECT_GT(part.area(), 0);
    }
    for (size_t i = 0; i < 4; ++i) {
      for (size_t j = i + 1; j < 4; ++j) EXPECT_EQ((parts[i] & parts[j]).area(), 0) << i << j;
    }
    EXPECT_TRUE(Inside(layout.panel, layout.figures));
    EXPECT_TRUE(Inside(layout.panel, layout.gauge));
    EXPECT_TRUE(Inside(layout.endoscope, layout.banner));
    EXPECT_EQ((layout.figures & layout.gauge).area(), 0);
    for (const auto& button : layout.buttons) {
      EXPECT_TRUE(Inside(layout.panel, button.rect)) << button.label;
      EXPECT_EQ((button.rect & layout.figures).area(), 0) << button.label;
      const cv::Point center = CenterOf(button.rect);
      ASSERT_TRUE(HitTestScreen(layout, center.x, center.y).has_value()) << button.label;
      EXPECT_EQ(*HitTestScreen(layout, center.x, center.y), button.action) << button.label;
    }
    // The endoscope image is the largest part: over a third of the screen.
    EXPECT_GT(layout.endoscope.area(), screen.area() / 3);
    const cv::Point in_view = CenterOf(layout.endoscope);
    EXPECT_FALSE(HitTestScreen(layout, in_view.x, in_view.y).has_value());
  }
}

TEST(ScreenLayout, SmallerScreensGetTheSameDesignScaledDown) {
  const ScreenLayout full = MakeScreenLayout({1920, 1080});
  const ScreenLayout small = MakeScreenLayout({1366, 768});
  EXPECT_DOUBLE_EQ(full.scale, 1.0);
  EXPECT_NEAR(small.scale, 768.0 / 1080.0, 1e-9);  // the height limits it
  EXPECT_NEAR(small.endoscope.width, full.endoscope.width * small.scale, 1.0);
  EXPECT_NEAR(small.fluoroscopy.x, full.fluoroscopy.x * small.scale, 1.0);
  // 4:3 areas for the 640x480 views.
  EXPECT_NEAR(static_cast<double>(small.endoscope.width) / small.endoscope.height, 4.0 / 3.0, 0.01);
}

TEST(PanelAction, ClicksSwitchModesTogglesAndTurnTheCarm) {
  ScreenModel model;
  ControlState state;
  ApplyPanelAction(PanelAction::kWireframe, model, &state);
  EXPECT_EQ(state.view_mode, ViewMode::kWireframe);
  ApplyPanelAction(PanelAction::kToggleFluoroscopy, model, &state);
  EXPECT_TRUE(state.fluoroscopy_visible);
  ApplyPanelAction(PanelAction::kToggleDamage, model, &state);
  EXPECT_TRUE(state.damage_display);
  ApplyPanelAction(PanelAction::kCarmRight, model, &state);
  EXPECT_NEAR(state.fluoro_yaw_rad, 15.0 * CV_PI / 180.0, 1e-12);
  ApplyPanelAction(PanelAction::kCarmLeft, model, &state);
  ApplyPanelAction(PanelAction::kCarmLeft, model, &state);
  EXPECT_NEAR(state.fluoro_yaw_rad, -15.0 * CV_PI / 180.0, 1e-12);
  ApplyPanelAction(PanelAction::kZoomIn, model, &state);
  EXPECT_NEAR(state.fluoro_zoom, kFluoroZoomPerWheelStep, 1e-12);
  ApplyPanelAction(PanelAction::kRepeat, model, &state);
  EXPECT_TRUE(state.repeat_requested);
}

TEST(PanelAction, CaseAndScopeChoiceWrapAround) {
  ScreenModel model;
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

TEST(DrawTextFitted, LongTextShrinksAndStaysInsideItsBox) {
  cv::Mat image(200, 400, CV_8UC3, cv::Scalar(0, 0, 0));
  const cv::Rect box(50, 80, 150, 30);
  const double used = DrawTextFitted(image, "device: SAFE STATE communication-lost (r re-arms)",
                                     box, 1.0, cv::Scalar(255, 255, 255));
  EXPECT_LT(used, 1.0);
  cv::Mat ink;
  cv::cvtColor(image, ink, cv::COLOR_BGR2GRAY);
  const int total = cv::countNonZero(ink);
  EXPECT_GT(total, 100);
  cv::Mat outside = ink.clone();
  outside(box).setTo(0);
  EXPECT_EQ(cv::countNonZero(outside), 0) << "text drawn outside its box";
  // Text that fits keeps its size.
  cv::Mat other(200, 400, CV_8UC3, cv::Scalar(0, 0, 0));
  EXPECT_EQ(DrawTextFitted(other, "ok", box, 0.6, cv::Scalar(255, 255, 255)), 0.6);
}

class Compose : public ::testing::Test {
 protected:
  ScreenLayout layout_ = MakeScreenLayout({1366, 768});
  cv::Mat endoscope_ = cv::Mat(480, 640, CV_8UC3, cv::Scalar(0, 0, 200));     // red
  cv::Mat fluoroscopy_ = cv::Mat(480, 640, CV_8UC3, cv::Scalar(200, 0, 0));   // blue
  ScreenModel model_;
  ControlState controls_;

  cv::Mat Draw() { return ComposeScreen(layout_, endoscope_, fluoroscopy_, model_, controls_); }
};

// Share of pixels that differ between two images inside `region`.
double ChangedIn(const cv::Mat& a, const cv::Mat& b, const cv::Rect& region) {
  cv::Mat diff;
  cv::absdiff(a(region), b(region), diff);
  cv::Mat grey;
  cv::cvtColor(diff, grey, cv::COLOR_BGR2GRAY);
  return static_cast<double>(cv::countNonZero(grey > 20)) / region.area();
}

TEST_F(Compose, EachViewFillsItsOwnArea) {
  const cv::Mat screen = Draw();
  ASSERT_EQ(screen.size(), cv::Size(1366, 768));
  EXPECT_EQ(screen.at<cv::Vec3b>(CenterOf(layout_.endoscope)), cv::Vec3b(0, 0, 200));
  EXPECT_EQ(screen.at<cv::Vec3b>(CenterOf(layout_.fluoroscopy)), cv::Vec3b(200, 0, 0));
  // Neither view spills over into the panel or the status strip.
  EXPECT_EQ(ChangedIn(screen, ComposeScreen(layout_, cv::Mat(), cv::Mat(), model_, controls_),
                      layout_.panel),
            0.0);
}

TEST_F(Compose, XrayOffSaysSoInsteadOfAnImage) {
  const cv::Mat on = Draw();
  fluoroscopy_ = cv::Mat();
  const cv::Mat off = Draw();
  EXPECT_GT(ChangedIn(on, off, layout_.fluoroscopy), 0.5);
  EXPECT_EQ(ChangedIn(on, off, layout_.endoscope), 0.0);
  // The message is there (text on black), not an empty area.
  cv::Mat grey;
  cv::cvtColor(off(layout_.fluoroscopy), grey, cv::COLOR_BGR2GRAY);
  EXPECT_GT(cv::countNonZero(grey > 100), 200);
}

TEST_F(Compose, ActiveModeButtonIsHighlighted) {
  controls_.view_mode = ViewMode::kTextured;
  const cv::Mat texture = Draw();
  controls_.view_mode = ViewMode::kWireframe;
  const cv::Mat wire = Draw();
  EXPECT_GT(ChangedIn(texture, wire, ButtonFor(layout_, PanelAction::kWireframe).rect), 0.5);
  EXPECT_GT(ChangedIn(texture, wire, ButtonFor(layout_, PanelAction::kTexture).rect), 0.5);
  EXPECT_EQ(ChangedIn(texture, wire, layout_.fluoroscopy), 0.0);
  EXPECT_EQ(ChangedIn(texture, wire, layout_.figures), 0.0);
}

TEST_F(Compose, FiguresChangeOnlyTheFigures) {
  const cv::Mat before = Draw();
  model_.inserted_m = 0.52;
  model_.tip_arc_m = 0.41;
  model_.tip_region = "sigmoid";
  const cv::Mat after = Draw();
  EXPECT_GT(ChangedIn(before, after, layout_.figures), 0.0);
  EXPECT_EQ(ChangedIn(before, after, layout_.endoscope), 0.0);
  EXPECT_EQ(ChangedIn(before, after, layout_.gauge), 0.0);
  EXPECT_EQ(ChangedIn(before, after, layout_.status), 0.0);
}

TEST_F(Compose, ThePressAndThePatientsPositionShowInTheFiguresOnly) {
  const cv::Mat before = Draw();
  controls_.abdominal_press = AbdominalPress::kMidAbdomen;
  const cv::Mat pressed = Draw();
  controls_.patient_position = PatientPosition::kRightLateral;
  const cv::Mat turned = Draw();
  for (const auto& [a, b] : {std::pair{&before, &pressed}, std::pair{&pressed, &turned}}) {
    EXPECT_GT(ChangedIn(*a, *b, layout_.figures), 0.0);
    EXPECT_EQ(ChangedIn(*a, *b, layout_.endoscope), 0.0);
    EXPECT_EQ(ChangedIn(*a, *b, layout_.fluoroscopy), 0.0);
    EXPECT_EQ(ChangedIn(*a, *b, layout_.gauge), 0.0);
    EXPECT_EQ(ChangedIn(*a, *b, layout_.status), 0.0);
  }
  // Each on its own line: the press on the left, the position on the right.
  const cv::Rect& f = layout_.figures;
  const cv::Rect last_line(f.x, f.y + f.height * 5 / 6, f.width, f.height - f.height * 5 / 6);
  const cv::Rect left(last_line.x, last_line.y, last_line.width / 2, last_line.height);
  const cv::Rect right(last_line.x + last_line.width * 3 / 5, last_line.y,
                       last_line.width - last_line.width * 3 / 5, last_line.height);
  EXPECT_GT(ChangedIn(before, pressed, left), 0.0);
  EXPECT_EQ(ChangedIn(before, pressed, right), 0.0);
  EXPECT_GT(ChangedIn(pressed, turned, right), 0.0);
  EXPECT_EQ(ChangedIn(pressed, turned, left), 0.0);
  const cv::Rect upper_lines(f.x, f.y, f.width, f.height * 5 / 6 - 2);
  EXPECT_EQ(ChangedIn(before, turned, upper_lines), 0.0);
}

TEST_F(Compose, ForceGaugeGrowsWithForceAndTurnsRedWhenExcessive) {
  model_.force_gauge_max_N = 10.0;
  model_.hand_limit_N = 5.0;
  const cv::Rect& g = layout_.gauge;
  const cv::Point probe(g.x + g.width * 6 / 10, g.y + 2);  // right of the threshold mark
  model_.hand_force_N = 2.0;
  const cv::Vec3b low = Draw().at<cv::Vec3b>(probe);
  model_.hand_force_N = 8.0;
  const cv::Vec3b high = Draw().at<cv::Vec3b>(probe);
  EXPECT_NE(low, high);
  EXPECT_GT(high[2], high[1]);  // red (BGR) dominates over green above the threshold
}

TEST_F(Compose, SessionOverShowsABannerOverTheEndoscopeOnly) {
  model_.phase = SessionPhase::kRunning;
  const cv::Mat running = Draw();
  model_.phase = SessionPhase::kOver;
  model_.outcome = "time limit reached";
  model_.score = 34.0;
  const cv::Mat over = Draw();
  EXPECT_GT(ChangedIn(running, over, layout_.banner), 0.5);
  EXPECT_EQ(ChangedIn(running, over, layout_.fluoroscopy), 0.0);
  EXPECT_EQ(ChangedIn(running, over, layout_.panel), 0.0);
  EXPECT_GT(ChangedIn(running, over, layout_.status), 0.0);  // the clock line says "over"
}

TEST_F(Compose, DeviceStateIsColouredBySeverity) {
  const auto colour_count = [&](DeviceStatus status, int channel) {
    model_.device_status = status;
    model_.device_text = "x";
    cv::Mat channels[3];
    cv::split(Draw()(layout_.status), channels);
    return cv::countNonZero(channels[channel] > 200);
  };
  EXPECT_GT(colour_count(DeviceStatus::kSafe, 2), colour_count(DeviceStatus::kOk, 2));
}

}  // namespace
}  // namespace ves::ui
