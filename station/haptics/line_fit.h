#pragma once

// Least-squares line and the summary figures of the paper's Fig. 5/6
// experiments: RMS and peak of the load, and the load-vs-displacement slope
// with its coefficient of determination R².
#include <vector>

namespace ves::haptics {

struct LineFit {
  double slope{0.0};
  double intercept{0.0};
  double r2{0.0};  // 0 when x or y does not vary
};

// Throws std::invalid_argument if the sizes differ or fewer than 2 points.
LineFit FitLine(const std::vector<double>& x, const std::vector<double>& y);

struct AxisSummary {
  double rms_load{0.0};      // N or N·m
  double max_abs_load{0.0};  // N or N·m
  LineFit fit{};             // load against displacement: N/m or N·m/rad
};

AxisSummary SummarizeAxis(const std::vector<double>& displacement, const std::vector<double>& load);

}  // namespace ves::haptics
