#include "station/render/mucosa_seen.h"

#include <stdexcept>
#include <string>

namespace ves::render {

void MucosaSeenMap::Reset(int rings, int sectors) {
  if (rings < 1 || sectors < 1) {
    throw std::invalid_argument("mucosa seen map needs rings >= 1 and sectors >= 1, not " +
                                std::to_string(rings) + " x " + std::to_string(sectors));
  }
  rings_ = rings;
  sectors_ = sectors;
  seen_count_ = 0;
  seen_.assign(static_cast<size_t>(rings) * sectors, 0);
}

bool MucosaSeenMap::Mark(int ring, int sector) {
  if (ring < 0 || ring >= rings_ || sector < 0 || sector >= sectors_) return false;
  unsigned char& cell = seen_[static_cast<size_t>(ring) * sectors_ + sector];
  if (cell == 0) {
    cell = 1;
    ++seen_count_;
  }
  return true;
}

bool MucosaSeenMap::IsSeen(int ring, int sector) const {
  if (ring < 0 || ring >= rings_ || sector < 0 || sector >= sectors_) return false;
  return seen_[static_cast<size_t>(ring) * sectors_ + sector] != 0;
}

double MucosaSeenMap::SeenShare() const {
  return seen_.empty() ? 0.0 : static_cast<double>(seen_count_) / static_cast<double>(seen_.size());
}

}  // namespace ves::render
