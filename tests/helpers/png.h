// A small PNG reader for the tests that look at screenshots: 8-bit RGB or RGBA, not interlaced (what
// Chromium writes). Header-only, on zlib.
#pragma once

#include <zlib.h>

#include <cstdint>
#include <cstdlib>
#include <stdexcept>
#include <string>
#include <vector>

namespace polyhex::test {

struct Image {
  int width = 0, height = 0;
  std::vector<std::uint8_t> rgb;  ///< width * height * 3, rows top to bottom
  const std::uint8_t* at(int x, int y) const { return &rgb[(size_t(y) * size_t(width) + size_t(x)) * 3]; }
};

/// Decodes the PNG file content `png`.
/// \throw std::runtime_error for what is not an 8-bit RGB/RGBA non-interlaced PNG, or a corrupt one
inline Image decode_png(const std::string& png) {
  auto fail = [](const std::string& why) { throw std::runtime_error("png: " + why); };
  auto be32 = [&](size_t at) {
    return std::uint32_t(std::uint8_t(png[at])) << 24 | std::uint32_t(std::uint8_t(png[at + 1])) << 16 |
           std::uint32_t(std::uint8_t(png[at + 2])) << 8 | std::uint32_t(std::uint8_t(png[at + 3]));
  };
  if (png.size() < 8 || png.compare(0, 8, "\x89PNG\r\n\x1a\n") != 0) fail("not a PNG");
  Image img;
  int channels = 0;
  std::string idat;
  for (size_t at = 8; at + 12 <= png.size();) {
    const std::uint32_t len = be32(at);
    const std::string type = png.substr(at + 4, 4);
    if (at + 12 + len > png.size()) fail("truncated chunk " + type);
    if (type == "IHDR") {
      img.width = int(be32(at + 8));
      img.height = int(be32(at + 12));
      const int depth = std::uint8_t(png[at + 16]), colour = std::uint8_t(png[at + 17]),
                interlace = std::uint8_t(png[at + 20]);
      if (depth != 8 || (colour != 2 && colour != 6) || interlace != 0)
        fail("only 8-bit RGB/RGBA non-interlaced (depth " + std::to_string(depth) + ", colour type " +
             std::to_string(colour) + ")");
      channels = colour == 2 ? 3 : 4;
    } else if (type == "IDAT") {
      idat.append(png, at + 8, len);
    } else if (type == "IEND") {
      break;
    }
    at += 12 + len;
  }
  if (channels == 0 || img.width <= 0 || img.height <= 0) fail("no IHDR");
  const size_t stride = size_t(img.width) * size_t(channels);
  std::vector<std::uint8_t> raw((stride + 1) * size_t(img.height));
  uLongf raw_len = uLongf(raw.size());
  if (uncompress(raw.data(), &raw_len, reinterpret_cast<const Bytef*>(idat.data()), uLong(idat.size())) != Z_OK ||
      raw_len != raw.size())
    fail("corrupt image data");
  // Undo the per-row filters (PNG spec, section 9).
  std::vector<std::uint8_t> cur(stride), prev(stride, 0);
  img.rgb.resize(size_t(img.width) * size_t(img.height) * 3);
  for (int y = 0; y < img.height; ++y) {
    const std::uint8_t* row = &raw[size_t(y) * (stride + 1)];
    const int filter = row[0];
    for (size_t i = 0; i < stride; ++i) {
      const int a = i >= size_t(channels) ? cur[i - size_t(channels)] : 0, b = prev[i],
                c = i >= size_t(channels) ? prev[i - size_t(channels)] : 0;
      int pred = 0;
      switch (filter) {
        case 0:
          pred = 0;
          break;
        case 1:
          pred = a;
          break;
        case 2:
          pred = b;
          break;
        case 3:
          pred = (a + b) / 2;
          break;
        case 4: {
          const int p = a + b - c, pa = std::abs(p - a), pb = std::abs(p - b), pc = std::abs(p - c);
          pred = pa <= pb && pa <= pc ? a : pb <= pc ? b : c;
          break;
        }
        default:
          fail("bad filter " + std::to_string(filter));
      }
      cur[i] = std::uint8_t(row[1 + i] + pred);
    }
    for (int x = 0; x < img.width; ++x)
      for (int k = 0; k < 3; ++k)
        img.rgb[(size_t(y) * size_t(img.width) + size_t(x)) * 3 + size_t(k)] =
            cur[size_t(x) * size_t(channels) + size_t(k)];
    std::swap(cur, prev);
  }
  return img;
}

}  // namespace polyhex::test
