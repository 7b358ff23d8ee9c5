#pragma once

#include <vector>

namespace ves::render {

// Which patches of the colon wall the trainee has seen (the "% mucosa seen"
// metric of validated simulators, DESIGN.md §5): the wall is cut into model
// rings x sectors around; a patch counts once it has been on screen, lit
// and close enough, in any frame since the last Reset.
class MucosaSeenMap {
 public:
  MucosaSeenMap() = default;
  MucosaSeenMap(int rings, int sectors) { Reset(rings, sectors); }

  // Clears everything; throws std::invalid_argument for rings < 1 or sectors < 1.
  void Reset(int rings, int sectors);
  // Marks one patch; indices out of range are ignored (returns false).
  bool Mark(int ring, int sector);
  bool IsSeen(int ring, int sector) const;
  int rings() const { return rings_; }
  int sectors() const { return sectors_; }
  int seen_count() const { return seen_count_; }
  // Seen patches / all patches, in [0, 1]; 0 for an empty map.
  double SeenShare() const;

 private:
  int rings_{0};
  int sectors_{0};
  int seen_count_{0};
  std::vector<unsigned char> seen_;
};

}  // namespace ves::render
