#include "tests/station/app/xwd_image.h"

#include <cstdint>

namespace ves::station::testing {
namespace {

std::uint32_t BigEndian32(const std::string& bytes, std::size_t offset) {
  return (static_cast<std::uint32_t>(static_cast<unsigned char>(bytes[offset])) << 24) |
         (static_cast<std::uint32_t>(static_cast<unsigned char>(bytes[offset + 1])) << 16) |
         (static_cast<std::uint32_t>(static_cast<unsigned char>(bytes[offset + 2])) << 8) |
         static_cast<std::uint32_t>(static_cast<unsigned char>(bytes[offset + 3]));
}

int ShiftOf(std::uint32_t mask) {
  int shift = 0;
  while (mask != 0 && (mask & 1u) == 0) {
    mask >>= 1;
    ++shift;
  }
  return shift;
}

}  // namespace

cv::Mat DecodeXwd(const std::string& bytes) {
  // XWDFileHeader: 25 big-endian CARD32 fields, then the window name.
  if (bytes.size() < 100) return {};
  const auto field = [&](int index) { return BigEndian32(bytes, static_cast<std::size_t>(index) * 4); };
  const std::uint32_t header_size = field(0);
  const std::uint32_t width = field(4);
  const std::uint32_t height = field(5);
  const std::uint32_t byte_order = field(7);  // 0 LSBFirst, 1 MSBFirst
  const std::uint32_t bits_per_pixel = field(11);
  const std::uint32_t bytes_per_line = field(12);
  const std::uint32_t red_mask = field(14);
  const std::uint32_t green_mask = field(15);
  const std::uint32_t blue_mask = field(16);
  const std::uint32_t colormap_entries = field(19);
  if ((bits_per_pixel != 32 && bits_per_pixel != 24) || width == 0 || height == 0 ||
      width > 16384 || height > 16384) {
    return {};
  }
  const std::size_t start = header_size + static_cast<std::size_t>(colormap_entries) * 12;
  if (start + static_cast<std::size_t>(bytes_per_line) * height > bytes.size()) return {};
  const int bytes_per_pixel = static_cast<int>(bits_per_pixel / 8);
  const int red_shift = ShiftOf(red_mask);
  const int green_shift = ShiftOf(green_mask);
  const int blue_shift = ShiftOf(blue_mask);
  cv::Mat image(static_cast<int>(height), static_cast<int>(width), CV_8UC3);
  for (int y = 0; y < image.rows; ++y) {
    const auto* row = reinterpret_cast<const unsigned char*>(bytes.data()) + start +
                      static_cast<std::size_t>(y) * bytes_per_line;
    auto* out = image.ptr<cv::Vec3b>(y);
    for (int x = 0; x < image.cols; ++x) {
      const unsigned char* p = row + static_cast<std::size_t>(x) * bytes_per_pixel;
      std::uint32_t v = 0;
      for (int b = 0; b < bytes_per_pixel; ++b) {
        const int shift = byte_order == 0 ? 8 * b : 8 * (bytes_per_pixel - 1 - b);
        v |= static_cast<std::uint32_t>(p[b]) << shift;
      }
      out[x] = cv::Vec3b(static_cast<unsigned char>((v & blue_mask) >> blue_shift),
                         static_cast<unsigned char>((v & green_mask) >> green_shift),
                         static_cast<unsigned char>((v & red_mask) >> red_shift));
    }
  }
  return image;
}

}  // namespace ves::station::testing
