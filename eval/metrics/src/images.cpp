// Image helpers of the appearance measures: box-filtered MIP pyramids, bilinear reads, PSNR and
// SSIM (Wang, Bovik, Sheikh, Simoncelli, "Image quality assessment: from error visibility to
// structural similarity", IEEE TIP 2004).
#include "texdefrag/eval/appearance.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace texdefrag::eval {

std::vector<Image> mip_pyramid(const Image& img, int max_level) {
  if (img.width <= 0 || img.height <= 0 || img.channels < 1) throw std::invalid_argument("mip_pyramid: empty image");
  std::vector<Image> levels(1);
  Image& base = levels[0];
  base.width = img.width, base.height = img.height, base.channels = 3;
  base.pixels.resize(static_cast<size_t>(img.width) * static_cast<size_t>(img.height) * 3);
  for (int y = 0; y < img.height; ++y)
    for (int x = 0; x < img.width; ++x) {
      const uint8_t* s = img.at(x, y);
      uint8_t* d = base.at(x, y);
      for (int c = 0; c < 3; ++c) d[c] = s[img.channels >= 3 ? c : 0];
    }
  while (static_cast<int>(levels.size()) <= max_level && (levels.back().width > 1 || levels.back().height > 1)) {
    const Image& a = levels.back();
    Image b;
    b.width = (a.width + 1) / 2, b.height = (a.height + 1) / 2, b.channels = 3;
    b.pixels.resize(static_cast<size_t>(b.width) * static_cast<size_t>(b.height) * 3);
    for (int y = 0; y < b.height; ++y)
      for (int x = 0; x < b.width; ++x) {
        int sum[3] = {0, 0, 0}, n = 0;
        for (int dy = 0; dy < 2; ++dy)
          for (int dx = 0; dx < 2; ++dx) {
            const int sx = 2 * x + dx, sy = 2 * y + dy;
            if (sx >= a.width || sy >= a.height) continue;
            const uint8_t* p = a.at(sx, sy);
            for (int c = 0; c < 3; ++c) sum[c] += p[c];
            ++n;
          }
        uint8_t* d = b.at(x, y);
        for (int c = 0; c < 3; ++c) d[c] = static_cast<uint8_t>((sum[c] + n / 2) / n);
      }
    levels.push_back(std::move(b));
  }
  return levels;
}

void bilinear_rgb(const Image& img, double x, double y, double rgb[3], bool repeat) {
  const double fx = x - 0.5, fr = static_cast<double>(img.height) - y - 0.5;  // column, row (top down)
  const double x0 = std::floor(fx), r0 = std::floor(fr);
  const double tx = fx - x0, tr = fr - r0;
  const auto index = [repeat](double v, int n) {
    if (repeat) return static_cast<int>(v - static_cast<double>(n) * std::floor(v / n));  // v mod n, in [0, n)
    return static_cast<int>(std::clamp(v, 0.0, static_cast<double>(n - 1)));
  };
  const int c0 = index(x0, img.width), c1 = index(x0 + 1, img.width);
  const int w0 = index(r0, img.height), w1 = index(r0 + 1, img.height);
  const int ch = img.channels;
  const uint8_t* p00 = img.at(c0, w0);
  const uint8_t* p10 = img.at(c1, w0);
  const uint8_t* p01 = img.at(c0, w1);
  const uint8_t* p11 = img.at(c1, w1);
  for (int c = 0; c < 3; ++c) {
    const int k = ch >= 3 ? c : 0;
    rgb[c] = (1 - tr) * ((1 - tx) * p00[k] + tx * p10[k]) + tr * ((1 - tx) * p01[k] + tx * p11[k]);
  }
}

namespace {

void check_pair(const Image& a, const Image& b, const std::vector<uint8_t>& mask, const char* who) {
  if (a.width != b.width || a.height != b.height || a.channels != 3 || b.channels != 3 ||
      mask.size() != static_cast<size_t>(a.width) * static_cast<size_t>(a.height))
    throw std::invalid_argument(std::string(who) + ": images must be RGB of equal size, mask one byte per pixel");
}

std::vector<double> luma(const Image& im) {
  std::vector<double> y(static_cast<size_t>(im.width) * static_cast<size_t>(im.height));
  for (size_t i = 0; i < y.size(); ++i) {
    const uint8_t* p = &im.pixels[i * 3];
    y[i] = 0.299 * p[0] + 0.587 * p[1] + 0.114 * p[2];
  }
  return y;
}

/// Gaussian blur (sigma 1.5, radius 5), separable, truncated and renormalised at the border.
std::vector<double> gauss(const std::vector<double>& v, int w, int h) {
  constexpr int r = 5;
  double k[2 * r + 1];
  for (int i = -r; i <= r; ++i) k[i + r] = std::exp(-(i * i) / (2 * 1.5 * 1.5));
  std::vector<double> tmp(v.size()), out(v.size());
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      double s = 0, ws = 0;
      for (int i = std::max(-r, -x); i <= std::min(r, w - 1 - x); ++i) {
        s += k[i + r] * v[static_cast<size_t>(y) * static_cast<size_t>(w) + static_cast<size_t>(x + i)];
        ws += k[i + r];
      }
      tmp[static_cast<size_t>(y) * static_cast<size_t>(w) + static_cast<size_t>(x)] = s / ws;
    }
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      double s = 0, ws = 0;
      for (int i = std::max(-r, -y); i <= std::min(r, h - 1 - y); ++i) {
        s += k[i + r] * tmp[static_cast<size_t>(y + i) * static_cast<size_t>(w) + static_cast<size_t>(x)];
        ws += k[i + r];
      }
      out[static_cast<size_t>(y) * static_cast<size_t>(w) + static_cast<size_t>(x)] = s / ws;
    }
  return out;
}

}  // namespace

double psnr(const Image& a, const Image& b, const std::vector<uint8_t>& mask) {
  check_pair(a, b, mask, "psnr");
  double sq = 0;
  size_t n = 0;
  for (size_t i = 0; i < mask.size(); ++i) {
    if (!mask[i]) continue;
    ++n;
    for (size_t c = 0; c < 3; ++c) {
      const double d = static_cast<double>(a.pixels[i * 3 + c]) - static_cast<double>(b.pixels[i * 3 + c]);
      sq += d * d;
    }
  }
  if (n == 0) return std::nan("");
  const double mse = sq / (3.0 * static_cast<double>(n));
  return mse > 0 ? 10.0 * std::log10(255.0 * 255.0 / mse) : std::numeric_limits<double>::infinity();
}

double ssim(const Image& a, const Image& b, const std::vector<uint8_t>& mask) {
  check_pair(a, b, mask, "ssim");
  const int w = a.width, h = a.height;
  const std::vector<double> x = luma(a), y = luma(b);
  std::vector<double> xx(x.size()), yy(x.size()), xy(x.size());
  for (size_t i = 0; i < x.size(); ++i) xx[i] = x[i] * x[i], yy[i] = y[i] * y[i], xy[i] = x[i] * y[i];
  const std::vector<double> mx = gauss(x, w, h), my = gauss(y, w, h);
  const std::vector<double> sxx = gauss(xx, w, h), syy = gauss(yy, w, h), sxy = gauss(xy, w, h);
  const double c1 = (0.01 * 255) * (0.01 * 255), c2 = (0.03 * 255) * (0.03 * 255);
  double sum = 0;
  size_t n = 0;
  for (size_t i = 0; i < x.size(); ++i) {
    if (!mask[i]) continue;
    // note: written symmetrically so that identical images give exactly 1 (2ab == a*a + b*b).
    const double vx = sxx[i] - mx[i] * mx[i], vy = syy[i] - my[i] * my[i], cxy = sxy[i] - mx[i] * my[i];
    const double num = (2 * mx[i] * my[i] + c1) * (2 * cxy + c2);
    const double den = (mx[i] * mx[i] + my[i] * my[i] + c1) * (vx + vy + c2);
    sum += num / den;
    ++n;
  }
  return n ? sum / static_cast<double>(n) : std::nan("");
}

}  // namespace texdefrag::eval
