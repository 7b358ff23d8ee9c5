#include "station/ui/training_screen.h"

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace ves::ui {
namespace {

// The design canvas; every other size is this scaled uniformly.
constexpr double kDesignWidth = 1920.0;
constexpr double kDesignHeight = 1080.0;
constexpr double kCarmStepRad = 0.2617993877991494;  // 15 degrees
constexpr double kDegPerRad = 57.29577951308232;

const cv::Scalar kBackground(28, 28, 28);
const cv::Scalar kFrame(70, 70, 70);
const cv::Scalar kButton(88, 88, 88);
const cv::Scalar kButtonActive(60, 140, 60);
const cv::Scalar kText(235, 235, 235);
const cv::Scalar kDim(170, 170, 170);
const cv::Scalar kGreen(70, 180, 70);
const cv::Scalar kAmber(40, 170, 230);
const cv::Scalar kRed(50, 50, 225);

int Wrap(int index, int delta, std::size_t size) {
  if (size == 0) return 0;
  const int n = static_cast<int>(size);
  return ((index + delta) % n + n) % n;
}

std::string NameAt(const std::vector<std::string>& names, int index) {
  return names.empty() ? "-" : names[static_cast<std::size_t>(Wrap(index, 0, names.size()))];
}

bool IsActive(PanelAction action, const ControlState& state) {
  switch (action) {
    case PanelAction::kWireframe: return state.view_mode == ViewMode::kWireframe;
    case PanelAction::kPolygon: return state.view_mode == ViewMode::kFlat;
    case PanelAction::kTexture: return state.view_mode == ViewMode::kTextured;
    case PanelAction::kToggleFluoroscopy: return state.fluoroscopy_visible;
    case PanelAction::kToggleDamage: return state.damage_display;
    default: return false;
  }
}

// A value that prints as zero at `resolution` is zero: no "-0.0".
double Shown(double value, double resolution) {
  return std::abs(value) < 0.5 * resolution ? 0.0 : value;
}

std::string Format(const char* format, double a, double b = 0.0, double c = 0.0) {
  char text[160];
  std::snprintf(text, sizeof text, format, a, b, c);
  return text;
}

const char* ModeName(ViewMode mode) {
  switch (mode) {
    case ViewMode::kWireframe: return "wire-frame";
    case ViewMode::kFlat: return "polygon";
    case ViewMode::kTextured: break;
  }
  return "texture";
}

// `image` scaled into `box` keeping its aspect ratio, centred; the rest dark.
void PutImage(cv::Mat& canvas, const cv::Mat& image, const cv::Rect& box) {
  cv::rectangle(canvas, box, cv::Scalar(0, 0, 0), cv::FILLED);
  if (image.empty()) return;
  const double fit = std::min(static_cast<double>(box.width) / image.cols,
                              static_cast<double>(box.height) / image.rows);
  const cv::Size size(std::max(1, static_cast<int>(image.cols * fit)),
                      std::max(1, static_cast<int>(image.rows * fit)));
  const cv::Rect target(box.x + (box.width - size.width) / 2,
                        box.y + (box.height - size.height) / 2, size.width, size.height);
  cv::Mat scaled;
  cv::resize(image, scaled, size, 0, 0, fit < 1.0 ? cv::INTER_AREA : cv::INTER_LINEAR);
  if (scaled.type() != canvas.type()) {
    cv::Mat converted;
    if (scaled.channels() == 1) {
      cv::cvtColor(scaled, converted, cv::COLOR_GRAY2BGR);
    } else if (scaled.channels() == 4) {
      cv::cvtColor(scaled, converted, cv::COLOR_BGRA2BGR);
    } else {
      scaled.convertTo(converted, canvas.type());
    }
    scaled = converted;
  }
  scaled.copyTo(canvas(target));
}

// A label on a dark band over the top-left corner of an image area.
void PutCaption(cv::Mat& canvas, const std::string& text, const cv::Rect& area, double scale) {
  const int height = static_cast<int>(34 * scale);
  const cv::Rect band(area.x, area.y, area.width, height);
  cv::Mat roi = canvas(band);
  roi *= 0.35;
  DrawTextFitted(canvas, text, band + cv::Point(static_cast<int>(10 * scale), 0) -
                                    cv::Size(static_cast<int>(20 * scale), 0),
                 0.75 * scale, kText);
}

}  // namespace

double DrawTextFitted(cv::Mat& image, const std::string& text, const cv::Rect& box, double scale,
                      const cv::Scalar& color, bool centred, int thickness) {
  constexpr int kFont = cv::FONT_HERSHEY_SIMPLEX;
  // Anti-aliasing and the stroke reach a pixel or two beyond the glyph box.
  const int room_x = box.width - 2 - thickness;
  const int room_y = box.height - 2 - thickness;
  int baseline = 0;
  cv::Size size = cv::getTextSize(text, kFont, scale, thickness, &baseline);
  const auto too_big = [&] { return size.width > room_x || size.height + baseline > room_y; };
  if (too_big() && size.width > 0) {
    scale *= std::min(static_cast<double>(room_x) / size.width,
                      static_cast<double>(room_y) / (size.height + baseline));
    size = cv::getTextSize(text, kFont, scale, thickness, &baseline);
    while (too_big() && scale > 0.05) {  // glyph sizes do not scale exactly
      scale *= 0.97;
      size = cv::getTextSize(text, kFont, scale, thickness, &baseline);
    }
  }
  const int x = box.x + 1 + (centred ? (room_x - size.width) / 2 : 0);
  const int top = box.y + 1 + (room_y - (size.height + baseline)) / 2;
  cv::putText(image, text, {x, top + size.height}, kFont, scale, color, thickness, cv::LINE_AA);
  return scale;
}

ScreenLayout MakeScreenLayout(cv::Size canvas) {
  ScreenLayout layout;
  layout.canvas = canvas;
  const double s = std::min(canvas.width / kDesignWidth, canvas.height / kDesignHeight);
  layout.scale = s;
  const double ox = (canvas.width - kDesignWidth * s) / 2.0;
  const double oy = (canvas.height - kDesignHeight * s) / 2.0;
  // Design coordinates (1920×1080) to canvas pixels.
  const auto R = [&](double x, double y, double w, double h) {
    const int x0 = static_cast<int>(std::lround(ox + x * s));
    const int y0 = static_cast<int>(std::lround(oy + y * s));
    const int x1 = static_cast<int>(std::lround(ox + (x + w) * s));
    const int y1 = static_cast<int>(std::lround(oy + (y + h) * s));
    return cv::Rect(x0, y0, x1 - x0, y1 - y0);
  };
  layout.endoscope = R(24, 24, 1232, 924);  // 4:3, as the rendered view
  layout.status = R(24, 960, 1232, 96);
  layout.fluoroscopy = R(1280, 24, 616, 462);
  layout.panel = R(1280, 498, 616, 558);
  layout.figures = R(1280, 810, 616, 194);
  layout.gauge = R(1280, 1012, 616, 40);
  layout.banner = R(24 + 24, 24 + 924 * 0.06, 1232 - 48, 924 * 0.90);
  layout.warning = R(24 + 24, 24 + 44, 1232 - 48, 64);

  const double row = 44;
  const double gap = 8;
  double y = 498;
  const auto add = [&](PanelAction action, double x, double w, const std::string& label) {
    layout.buttons.push_back({action, R(x, y, w, row), label});
  };
  const double third = (616 - 2 * gap) / 3;
  add(PanelAction::kWireframe, 1280, third, "1 Wire-frame");
  add(PanelAction::kPolygon, 1280 + third + gap, third, "2 Polygon");
  add(PanelAction::kTexture, 1280 + 2 * (third + gap), third, "3 Texture");
  y += row + gap;
  const double half = (616 - gap) / 2;
  add(PanelAction::kToggleFluoroscopy, 1280, half, "f  X-ray on/off");
  add(PanelAction::kToggleDamage, 1280 + half + gap, half, "g  Damage display");
  y += row + gap;
  const double quarter = (616 - 3 * gap) / 4;
  add(PanelAction::kCarmLeft, 1280, quarter, "C-arm -15");
  add(PanelAction::kCarmRight, 1280 + (quarter + gap), quarter, "C-arm +15");
  add(PanelAction::kZoomOut, 1280 + 2 * (quarter + gap), quarter, "- Zoom out");
  add(PanelAction::kZoomIn, 1280 + 3 * (quarter + gap), quarter, "+ Zoom in");
  y += row + gap;
  add(PanelAction::kRepeat, 1280, 616, "r  Repeat training");
  y += row + gap;
  add(PanelAction::kPreviousCase, 1280, row, "<");
  add(PanelAction::kNextCase, 1280 + 616 - row, row, ">");
  y += row + gap;
  add(PanelAction::kPreviousScope, 1280, row, "<");
  add(PanelAction::kNextScope, 1280 + 616 - row, row, ">");
  return layout;
}

std::optional<PanelAction> HitTestScreen(const ScreenLayout& layout, int x, int y) {
  for (const auto& button : layout.buttons) {
    if (button.rect.contains({x, y})) return button.action;
  }
  return std::nullopt;
}

void ApplyPanelAction(PanelAction action, const ScreenModel& model, ControlState* state) {
  switch (action) {
    case PanelAction::kWireframe: state->view_mode = ViewMode::kWireframe; break;
    case PanelAction::kPolygon: state->view_mode = ViewMode::kFlat; break;
    case PanelAction::kTexture: state->view_mode = ViewMode::kTextured; break;
    case PanelAction::kToggleFluoroscopy:
      state->fluoroscopy_visible = !state->fluoroscopy_visible;
      break;
    case PanelAction::kToggleDamage: state->damage_display = !state->damage_display; break;
    case PanelAction::kCarmLeft: state->fluoro_yaw_rad -= kCarmStepRad; break;
    case PanelAction::kCarmRight: state->fluoro_yaw_rad += kCarmStepRad; break;
    case PanelAction::kZoomOut: ApplyFluoroWheel(-1, state); break;
    case PanelAction::kZoomIn: ApplyFluoroWheel(1, state); break;
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

namespace {

// Design lengths to canvas pixels at scale s.
auto Scaler(double s) {
  return [s](double design) { return static_cast<int>(std::lround(design * s)); };
}

// The endoscope and fluoroscopy images, captioned and framed.
void DrawImages(cv::Mat& canvas, const ScreenLayout& layout, const cv::Mat& endoscope_bgr,
                const cv::Mat& fluoroscopy_bgr, const ScreenModel& model,
                const ControlState& controls) {
  const double s = layout.scale;
  const auto px = Scaler(s);
  PutImage(canvas, endoscope_bgr, layout.endoscope);
  if (endoscope_bgr.empty()) {
    DrawTextFitted(canvas, "starting ...", layout.endoscope, 1.2 * s, kDim, true);
  }
  PutCaption(canvas, std::string("Endoscope - ") + ModeName(controls.view_mode) + " view",
             layout.endoscope, s);

  // Fluoroscopy.
  PutImage(canvas, fluoroscopy_bgr, layout.fluoroscopy);
  if (fluoroscopy_bgr.empty()) {
    DrawTextFitted(canvas,
                   model.fluoroscopy_allowed ? "X-ray off (f)" : "X-ray not allowed in this lesson",
                   layout.fluoroscopy, 0.9 * s, kDim, true);
  }
  // The image names its view and tilt top right (render::DrawFluoroscopyLabels);
  // the caption keeps to the left half so the two never overlap.
  PutCaption(canvas,
             Format("Fluoroscopy  C-arm %+.0f, zoom %.1fx",
                    Shown(controls.fluoro_yaw_rad * kDegPerRad, 1.0), controls.fluoro_zoom),
             cv::Rect(layout.fluoroscopy.x, layout.fluoroscopy.y, layout.fluoroscopy.width / 2,
                      layout.fluoroscopy.height),
             s);
  cv::rectangle(canvas, layout.endoscope, kFrame, std::max(1, px(2)));
  cv::rectangle(canvas, layout.fluoroscopy, kFrame, std::max(1, px(2)));
}

// Buttons, case and scope.
void DrawButtonsAndChoices(cv::Mat& canvas, const ScreenLayout& layout, const ScreenModel& model,
                           const ControlState& controls) {
  const double s = layout.scale;
  const auto px = Scaler(s);
  for (const auto& button : layout.buttons) {
    cv::rectangle(canvas, button.rect, IsActive(button.action, controls) ? kButtonActive : kButton,
                  cv::FILLED);
    DrawTextFitted(canvas, button.label, button.rect - cv::Size(px(12), 0) + cv::Point(px(6), 0),
                   0.62 * s, kText, true);
  }
  const auto choice_box = [&](PanelAction previous) {
    for (const auto& button : layout.buttons) {
      if (button.action != previous) continue;
      return cv::Rect(button.rect.br().x + px(12), button.rect.y,
                      layout.panel.width - 2 * button.rect.width - px(24), button.rect.height);
    }
    return cv::Rect();
  };
  DrawTextFitted(canvas, "Case: " + NameAt(model.case_names, controls.case_choice),
                 choice_box(PanelAction::kPreviousCase), 0.62 * s, kText);
  DrawTextFitted(canvas, "Scope: " + NameAt(model.scope_names, controls.scope_choice),
                 choice_box(PanelAction::kPreviousScope), 0.62 * s, kText);
}

// Live figures: two columns of six lines; on the right what the score
// weighs, amber once it costs points, damage red.
void DrawLiveFigures(cv::Mat& canvas, const ScreenLayout& layout, const ScreenModel& model,
                     const ControlState& controls) {
  const double s = layout.scale;
  const auto px = Scaler(s);
  const ScoreFigures& sf = model.score_figures;
  const cv::Rect& f = layout.figures;
  constexpr int kLines = 6;
  const int line = f.height / kLines;
  const int left_width = f.width * 55 / 100;
  const std::string left[] = {
      Format("Inserted    %.2f m", model.inserted_m),
      Format("Tip depth   %.2f m", model.tip_arc_m) +
          (model.tip_region.empty() ? "" : "  " + model.tip_region),
      Format("Knobs  U/D %+.0f  L/R %+.0f deg", Shown(controls.knob_up_rad * kDegPerRad, 1.0),
             Shown(controls.knob_right_rad * kDegPerRad, 1.0)),
      Format("Roll   %+.0f deg", Shown(model.roll_rad * kDegPerRad, 1.0)),
      Format("Wall   %.1f N  (over %.0f N costs)", sf.wall_force_N, model.excessive_wall_force_N),
      std::string("Press  ") + PressName(controls.abdominal_press),
  };
  const std::string right[] = {
      Format("Pain      %.1f s", sf.pain_s),
      Format("Loop      %.1f s", sf.loop_s),
      Format("X-ray     %.1f s", sf.xray_s),
      Format("Red-out   %.1f s", sf.redout_s),
      sf.damage_events == 0 ? std::string("Damage    none")
                            : Format("Damage    %.0f  (-%.0f points)", sf.damage_events,
                                     sf.damage_events * model.damage_penalty_points),
      std::string("Patient   ") + PositionName(controls.patient_position),
  };
  const auto costs = [](double value) { return value > 0.0 ? kAmber : kText; };
  // The toolkit's line in amber while a press or a turned patient is in use.
  const cv::Scalar left_color[] = {
      kText, kText, kText, kText,
      sf.wall_force_N > model.damage_wall_force_N       ? kRed
      : sf.wall_force_N > model.excessive_wall_force_N ? kAmber
                                                       : kText,
      controls.abdominal_press == AbdominalPress::kNone ? kText : kAmber};
  const cv::Scalar right_color[] = {
      costs(sf.pain_s), costs(sf.loop_s), costs(sf.xray_s), costs(sf.redout_s),
      sf.damage_events > 0 ? kRed : kText,
      controls.patient_position == PatientPosition::kSupine ? kText : kAmber};
  for (int i = 0; i < kLines; ++i) {
    DrawTextFitted(canvas, left[i], {f.x, f.y + i * line, left_width - px(8), line}, 0.62 * s,
                   left_color[i]);
    DrawTextFitted(canvas, right[i], {f.x + left_width, f.y + i * line, f.width - left_width, line},
                   0.62 * s, right_color[i]);
  }
}

// Force gauge: the hand's axial force against the device's range, the
// hand's limit marked and labelled.
void DrawForceGauge(cv::Mat& canvas, const ScreenLayout& layout, const ScreenModel& model) {
  const double s = layout.scale;
  const auto px = Scaler(s);
  const cv::Rect& g = layout.gauge;
  cv::rectangle(canvas, g, kButton, cv::FILLED);
  const double share =
      std::clamp(std::abs(model.hand_force_N) / model.force_gauge_max_N, 0.0, 1.0);
  const bool excessive = std::abs(model.hand_force_N) > model.hand_limit_N;
  cv::rectangle(canvas, {g.x, g.y, static_cast<int>(share * g.width), g.height},
                excessive ? kRed : kGreen, cv::FILLED);
  const int limit_x =
      g.x + static_cast<int>(g.width * std::clamp(model.hand_limit_N / model.force_gauge_max_N,
                                                  0.0, 1.0));
  cv::line(canvas, {limit_x, g.y}, {limit_x, g.y + g.height - 1}, kText, std::max(1, px(2)));
  DrawTextFitted(canvas, Format("Hand force %.1f N", Shown(model.hand_force_N, 0.1)),
                 cv::Rect(g.x + px(8), g.y, limit_x - g.x - px(16), g.height), 0.62 * s, kText);
  DrawTextFitted(canvas, Format("| limit %.0f N (hand)", model.hand_limit_N),
                 cv::Rect(limit_x + px(4), g.y, g.br().x - limit_x - px(8), g.height), 0.55 * s,
                 kText);
}

// A damage episode: a red warning across the endoscope the moment the
// model reports it, for kDamageWarningHold_s.
void DrawDamageWarning(cv::Mat& canvas, const ScreenLayout& layout, const ScreenModel& model) {
  const double s = layout.scale;
  const auto px = Scaler(s);
  if (model.phase == SessionPhase::kRunning && DamageWarningOn(model.score_figures, model.elapsed_s)) {
    const cv::Rect& w = layout.warning;
    cv::rectangle(canvas, w, kRed, cv::FILLED);
    DrawTextFitted(canvas,
                   Format("DAMAGE: the wall held over %.0f N - ease off  (-%.0f points)",
                          model.damage_wall_force_N, model.damage_penalty_points),
                   w - cv::Size(px(24), 0) + cv::Point(px(12), 0), 0.9 * s, kText, true,
                   std::max(1, px(2)));
  }
}

// Status strip: clock and state, device, keys.
void DrawStatusStrip(cv::Mat& canvas, const ScreenLayout& layout, const ScreenModel& model) {
  const double s = layout.scale;
  const cv::Rect& st = layout.status;
  const cv::Rect top(st.x, st.y, st.width, st.height / 2);
  const cv::Rect bottom(st.x, st.y + st.height / 2, st.width, st.height - st.height / 2);
  std::string clock = Format("Session %.1f s", model.elapsed_s);
  if (model.time_limit_s > 0.0) clock += Format(" of %.0f s", model.time_limit_s);
  switch (model.phase) {
    case SessionPhase::kReady: clock += "  - ready: push the scope in to start"; break;
    case SessionPhase::kRunning: clock += "  - running"; break;
    case SessionPhase::kOver: clock += "  - over: " + model.outcome; break;
  }
  DrawTextFitted(canvas, clock, {top.x, top.y, top.width * 45 / 100, top.height}, 0.8 * s, kText);
  const cv::Scalar device_color = model.device_status == DeviceStatus::kOk           ? kGreen
                                  : model.device_status == DeviceStatus::kRecovering ? kAmber
                                                                                     : kRed;
  const cv::Rect device_box(top.x + top.width * 46 / 100, top.y, top.width * 54 / 100, top.height);
  DrawTextFitted(canvas, "Device: " + model.device_text, device_box, 0.7 * s, device_color);
  DrawTextFitted(
      canvas,
      "w/s insert  a/d roll  i/k j/l knobs  c centre  1 2 3 v view  f X-ray  g damage  "
      "+/- zoom  drag X-ray: rotate  p press  t patient  n/m case/scope  r repeat  q quit",
      bottom, 0.55 * s, kDim);
}

// Session over: a banner across the endoscope image with the debrief.
void DrawOverBanner(cv::Mat& canvas, const ScreenLayout& layout, const ScreenModel& model) {
  const double s = layout.scale;
  const auto px = Scaler(s);
  const cv::Rect& b = layout.banner;
  cv::Mat roi = canvas(b);
  roi *= 0.2;
  cv::rectangle(canvas, b, kAmber, std::max(1, px(3)));
  const int h = b.height;
  const cv::Rect inner(b.x + px(24), b.y, b.width - px(48), h);
  DrawTextFitted(canvas, "SESSION OVER: " + model.outcome,
                 {inner.x, b.y + h * 2 / 100, inner.width, h * 10 / 100}, 1.5 * s, kText, true,
                 std::max(1, px(3)));
  DrawTextFitted(canvas, Format("Score %.1f of %.0f", model.score, model.score_max),
                 {inner.x, b.y + h * 12 / 100, inner.width, h * 8 / 100}, 1.1 * s, kAmber, true,
                 std::max(1, px(2)));
  if (!model.debrief.parts.empty()) {
    DrawDebrief(canvas, {inner.x, b.y + h * 22 / 100, inner.width, h * 68 / 100}, model.debrief,
                model.sitting_line, s);
  }
  DrawTextFitted(canvas, "r: train again     q: finish",
                 {inner.x, b.y + h * 91 / 100, inner.width, h * 7 / 100}, 0.8 * s, kDim, true);
}

}  // namespace

cv::Mat ComposeScreen(const ScreenLayout& layout, const cv::Mat& endoscope_bgr,
                      const cv::Mat& fluoroscopy_bgr, const ScreenModel& model,
                      const ControlState& controls) {
  cv::Mat canvas(layout.canvas, CV_8UC3, kBackground);
  DrawImages(canvas, layout, endoscope_bgr, fluoroscopy_bgr, model, controls);
  DrawButtonsAndChoices(canvas, layout, model, controls);
  DrawLiveFigures(canvas, layout, model, controls);
  DrawForceGauge(canvas, layout, model);
  DrawDamageWarning(canvas, layout, model);
  DrawStatusStrip(canvas, layout, model);
  if (model.phase == SessionPhase::kOver) DrawOverBanner(canvas, layout, model);
  return canvas;
}

}  // namespace ves::ui
