#include "station/haptics/line_fit.h"

#include <cmath>
#include <stdexcept>
#include <string>

namespace ves::haptics {

LineFit FitLine(const std::vector<double>& x, const std::vector<double>& y) {
  if (x.size() != y.size() || x.size() < 2) {
    throw std::invalid_argument("FitLine needs two equal-sized series of >= 2 points, got " +
                                std::to_string(x.size()) + " and " + std::to_string(y.size()));
  }
  const double n = static_cast<double>(x.size());
  double mean_x = 0.0;
  double mean_y = 0.0;
  for (std::size_t i = 0; i < x.size(); ++i) {
    mean_x += x[i];
    mean_y += y[i];
  }
  mean_x /= n;
  mean_y /= n;
  double sxx = 0.0;
  double syy = 0.0;
  double sxy = 0.0;
  for (std::size_t i = 0; i < x.size(); ++i) {
    sxx += (x[i] - mean_x) * (x[i] - mean_x);
    syy += (y[i] - mean_y) * (y[i] - mean_y);
    sxy += (x[i] - mean_x) * (y[i] - mean_y);
  }
  LineFit fit;
  if (sxx > 0.0) {
    fit.slope = sxy / sxx;
    fit.intercept = mean_y - fit.slope * mean_x;
    if (syy > 0.0) fit.r2 = sxy * sxy / (sxx * syy);
  } else {
    fit.intercept = mean_y;
  }
  return fit;
}

AxisSummary SummarizeAxis(const std::vector<double>& displacement,
                          const std::vector<double>& load) {
  AxisSummary summary;
  summary.fit = FitLine(displacement, load);
  double sum_squares = 0.0;
  for (double value : load) {
    sum_squares += value * value;
    summary.max_abs_load = std::max(summary.max_abs_load, std::abs(value));
  }
  summary.rms_load = std::sqrt(sum_squares / static_cast<double>(load.size()));
  return summary;
}

}  // namespace ves::haptics
