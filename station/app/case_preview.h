#pragma once

#include <opencv2/core.hpp>

#include "ves/v1/case.pb.h"

// The picture `ves-station import-case --preview DIR` writes after an import
// (docs/case-format.md): the case's colon at rest on AP fluoroscopy, framed
// whole, each region's name at its middle, so whoever imported it sees at a
// glance that the anus is at the bottom and the regions are where they belong.
namespace ves::station {

// 8-bit BGR, width x height. Throws std::invalid_argument (a case the model
// refuses) or render::RenderError (no GL).
cv::Mat RenderCasePreview(const ves::v1::ColonCase& colon_case, int width, int height);

}  // namespace ves::station
