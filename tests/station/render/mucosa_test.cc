#include <gtest/gtest.h>

#include <opencv2/imgcodecs.hpp>
#include <stdexcept>

#include "station/render/mucosa_texture.h"

namespace ves::render {
namespace {

double MeanAbsDiff(const cv::Mat& a, const cv::Mat& b) {
  cv::Mat diff;
  cv::absdiff(a, b, diff);
  const cv::Scalar m = cv::mean(diff);
  return (m[0] + m[1] + m[2]) / 3.0;
}

TEST(MucosaTexture, IsDeterministicForASeed) {
  const cv::Mat a = MakeProceduralMucosa(128, 7);
  const cv::Mat b = MakeProceduralMucosa(128, 7);
  const cv::Mat c = MakeProceduralMucosa(128, 8);
  EXPECT_EQ(MeanAbsDiff(a, b), 0.0);
  EXPECT_GT(MeanAbsDiff(a, c), 1.0);
}

TEST(MucosaTexture, IsPinkWithDarkerVessels) {
  const cv::Mat image = MakeProceduralMucosa(256, 3);
  const cv::Scalar mean = cv::mean(image);  // BGR
  EXPECT_GT(mean[2], mean[1] + 40.0);       // red dominates
  EXPECT_GT(mean[2], mean[0] + 40.0);
  double min_red = 0.0;
  double max_red = 0.0;
  cv::Mat red;
  cv::extractChannel(image, red, 2);
  cv::minMaxLoc(red, &min_red, &max_red);
  cv::Mat green;
  cv::extractChannel(image, green, 1);
  double min_green = 0.0;
  cv::minMaxLoc(green, &min_green);
  EXPECT_LT(min_green, 90.0);  // vessels: green well below the mucosa's ~135
}

TEST(MucosaTexture, TilesWithoutASeam) {
  // The wrap-around step (last column → first) must look like any step
  // between neighbouring columns, not like a jump between unrelated pixels.
  const cv::Mat image = MakeProceduralMucosa(256, 5);
  const int n = image.cols;
  const double seam = MeanAbsDiff(image.col(n - 1), image.col(0));
  const double inner = MeanAbsDiff(image.col(n / 2), image.col(n / 2 + 1));
  const double unrelated = MeanAbsDiff(image.col(0), image.col(n / 2));
  EXPECT_LT(seam, 3.0 * inner + 1.0);
  EXPECT_LT(seam, unrelated);
  const double seam_rows = MeanAbsDiff(image.row(n - 1), image.row(0));
  EXPECT_LT(seam_rows, 3.0 * MeanAbsDiff(image.row(n / 2), image.row(n / 2 + 1)) + 1.0);
}

TEST(MucosaTexture, DecodesACaseImageAndRejectsGarbage) {
  const cv::Mat image = MakeProceduralMucosa(32, 1);
  std::vector<uchar> png;
  ASSERT_TRUE(cv::imencode(".png", image, png));
  const cv::Mat decoded = DecodeMucosaTexture(std::string(png.begin(), png.end()));
  EXPECT_EQ(MeanAbsDiff(decoded, image), 0.0);
  EXPECT_THROW(DecodeMucosaTexture("not an image"), std::invalid_argument);
  EXPECT_THROW(DecodeMucosaTexture(""), std::invalid_argument);
  EXPECT_THROW(MakeProceduralMucosa(4), std::invalid_argument);
}

}  // namespace
}  // namespace ves::render
