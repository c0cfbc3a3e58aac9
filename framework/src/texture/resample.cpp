// Texture resampling of the output atlas: the texture transfer step shared by Liu et al. 2024
// ("planar feature-preserving texture defragmentation", Remote Sensing) and the M-method
// (Maggiordomo et al. 2021, "Texture defragmentation for photo-reconstructed 3D models"): every
// output triangle is rasterised on its output page and its texels are fetched from the input page
// through the triangle's affine map; faces moved by whole texels (and multiples of 90 degrees) are
// copied bit-exact; the background is filled by pull-push (Gortler et al. 1996, "The Lumigraph",
// as the M-method does) or by dilation.
//
// Conventions (docs/texture.md): texel space has y up, texel (i, j) (column, row from the top) of a
// W x H page covers [i, i+1] x [H-j-1, H-j] and its centre is (i + 0.5, H - j - 0.5). Input
// sampling works in "grid" coordinates where integers are texel centres: gx = u - 0.5,
// gy = H - v - 0.5.
#include "texdefrag/texture/resample.h"

#include "texdefrag/util/parallel.h"

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cstring>
#include <exception>
#include <limits>
#include <memory>
#include <mutex>
#include <sstream>
#include <thread>

namespace texdefrag {
namespace {

/// Texels: a face map is an exact copy when all three corners agree with the snapped
/// rotation + integer translation to within this distance. note: any error below ~1e-3 texel would
/// round to the same bytes with bilinear filtering anyway; 1e-6 leaves room for OBJ round-trips.
constexpr double kCopyTolerance = 1e-6;
/// L-infinity radius (texels) of the conservative border: every texel whose centre is closer than
/// this to a triangle gets colour. note: bilinear lookups at a point p read the texels whose
/// centres are less than 1 texel from p on both axes, so radius 1 is exactly what a lookup
/// anywhere inside the chart needs (a half-texel "square touches" border misses texels along
/// slanted edges).
constexpr double kBorderRadius = 1.0;
/// Largest stretch (input texels per output texel) for which border texels extrapolate the affine
/// map; beyond it (slivers) they take the colour of the nearest point of the triangle instead.
constexpr double kMaxExtrapolationStretch = 4.0;
/// Relative threshold on |2 * area| / (longest edge)^2 below which an output triangle is degenerate.
constexpr double kDegenerateRatio = 1e-12;
/// Largest supported page side (texels), to keep index arithmetic in range.
constexpr int kMaxPageSide = 1 << 16;

constexpr uint8_t kEmpty = 0, kBorder = 1, kInterior = 2, kCoverMask = 3, kCopied = 4;

[[noreturn]] void fail(const std::string& what) { throw StageError("texture.resample: " + what); }

// ------------------------------------------------------------------------------------------------
// Sampling: repeat addressing (the MTL default) or clamp-to-edge (`map_Kd -clamp on`)

inline int clampi(long long v, int hi) { return static_cast<int>(v < 0 ? 0 : (v > hi ? hi : v)); }
/// Texel index `v` on an axis of `n` texels: wrapped (repeat) or clamped to the edge.
inline int address(long long v, int n, bool repeat) {
  if (v >= 0 && v < n) return static_cast<int>(v);
  if (!repeat) return v < 0 ? 0 : n - 1;
  const long long r = v % n;
  return static_cast<int>(r < 0 ? r + n : r);
}
/// Clamps a grid coordinate before conversion to an integer (extrapolated maps can be huge).
/// (NaN, from a near-singular map, goes to the low edge.)
inline double clamp_grid(double g, int size) {
  const double hi = static_cast<double>(size) + 3.0;
  return g > -4.0 ? (g < hi ? g : hi) : -4.0;
}
/// A grid coordinate for sampling: with repeat addressing, one far outside the page is first
/// brought into [0, size) by whole periods (the taps then wrap); then clamp_grid.
inline double grid(double g, int size, bool repeat) {
  if (repeat && !(g >= -2.0 && g < size + 2.0) && std::abs(g) < 1e15)
    g -= std::floor(g / size) * static_cast<double>(size);
  return clamp_grid(g, size);
}

/// floor() of a clamped grid coordinate (>= -4): truncation of a positive shift, much cheaper
/// than std::floor without SSE4.1.
inline int ifloor(double g) { return static_cast<int>(g + 16.0) - 16; }

/// A texel's channels, padded to four lanes (the lanes from C on stay 0): one SSE register, so the
/// fit's products and the block fill run on every channel at once (GCC's vector types). Each
/// lane's arithmetic is the scalar code's, operation for operation, and lanes never mix, so the
/// values are those of the channel-by-channel code, bit for bit.
using Lanes = float __attribute__((vector_size(16)));
using IntLanes = int __attribute__((vector_size(16)));

/// The C channels of a texel as lanes (the others 0).
template <int C>
Lanes texel_lanes(const uint8_t* p) {
  Lanes v = {};
  for (int c = 0; c < C; ++c) v[c] = static_cast<float>(p[c]);
  return v;
}

/// The C channels of a texel as integer lanes (the others 0).
template <int C>
IntLanes texel_ints(const uint8_t* p) {
  IntLanes v = {};
  for (int c = 0; c < C; ++c) v[c] = p[c];
  return v;
}

/// Rounds to the nearest byte value, clamping to [0, 255] (NaN gives 0).
inline uint8_t to_byte(float v) {
  const float r = v + 0.5f;
  if (!(r > 0.f)) return 0;
  if (r >= 255.f) return 255;
  return static_cast<uint8_t>(static_cast<int>(r));
}

inline float catmull_rom(float t, int k) {
  // weights of taps -1, 0, 1, 2 at fractional position t in [0, 1)
  const float t2 = t * t, t3 = t2 * t;
  switch (k) {
    case 0: return 0.5f * (-t3 + 2.f * t2 - t);
    case 1: return 0.5f * (3.f * t3 - 5.f * t2 + 2.f);
    case 2: return 0.5f * (-3.f * t3 + 4.f * t2 + t);
    default: return 0.5f * (t3 - t2);
  }
}

template <int C>
struct Sampler {
  const uint8_t* px = nullptr;
  int w = 0, h = 0;
  bool repeat = true;  ///< addressing outside the page: repeat, or clamp to the edge

  const uint8_t* texel(int x, int y) const {
    return px + (static_cast<size_t>(y) * static_cast<size_t>(w) + static_cast<size_t>(x)) * C;
  }
  /// The texel at any integer index, through the page's addressing.
  const uint8_t* texel_at(long long x, long long y) const { return texel(address(x, w, repeat), address(y, h, repeat)); }

  void nearest(double gx, double gy, uint8_t* out) const {
    std::memcpy(out, texel_at(ifloor(grid(gx, w, repeat) + 0.5), ifloor(grid(gy, h, repeat) + 0.5)), C);
  }

  void bilinear(double gx, double gy, uint8_t* out) const {
    float v[C];
    bilinear_f(gx, gy, v);
    for (int c = 0; c < C; ++c) out[c] = to_byte(v[c]);
  }

  /// bilinear_f's values as lanes (the others 0): the same operations on every channel at once.
  Lanes bilinear_lanes(double gx, double gy) const {
    gx = grid(gx, w, repeat);
    gy = grid(gy, h, repeat);
    const int x0 = ifloor(gx), y0 = ifloor(gy);
    const float fx = static_cast<float>(gx - x0), fy = static_cast<float>(gy - y0);
    const int xa = address(x0, w, repeat), xb = address(x0 + 1, w, repeat);
    const int ya = address(y0, h, repeat), yb = address(y0 + 1, h, repeat);
    const IntLanes i00 = texel_ints<C>(texel(xa, ya)), i10 = texel_ints<C>(texel(xb, ya));
    const IntLanes i01 = texel_ints<C>(texel(xa, yb)), i11 = texel_ints<C>(texel(xb, yb));
    const Lanes top = __builtin_convertvector(i00, Lanes) + fx * __builtin_convertvector(i10 - i00, Lanes);
    const Lanes bot = __builtin_convertvector(i01, Lanes) + fx * __builtin_convertvector(i11 - i01, Lanes);
    return top + fy * (bot - top);
  }

  /// Bilinear value without rounding (the least-squares fit's target).
  void bilinear_f(double gx, double gy, float* out) const {
    gx = grid(gx, w, repeat);
    gy = grid(gy, h, repeat);
    const int x0 = ifloor(gx), y0 = ifloor(gy);
    const float fx = static_cast<float>(gx - x0), fy = static_cast<float>(gy - y0);
    const int xa = address(x0, w, repeat), xb = address(x0 + 1, w, repeat);
    const int ya = address(y0, h, repeat), yb = address(y0 + 1, h, repeat);
    const uint8_t *p00 = texel(xa, ya), *p10 = texel(xb, ya), *p01 = texel(xa, yb), *p11 = texel(xb, yb);
    for (int c = 0; c < C; ++c) {
      const float top = static_cast<float>(p00[c]) + fx * static_cast<float>(p10[c] - p00[c]);
      const float bot = static_cast<float>(p01[c]) + fx * static_cast<float>(p11[c] - p01[c]);
      out[c] = top + fy * (bot - top);
    }
  }

  void bicubic(double gx, double gy, uint8_t* out) const {
    gx = grid(gx, w, repeat);
    gy = grid(gy, h, repeat);
    const int x0 = ifloor(gx), y0 = ifloor(gy);
    const float tx = static_cast<float>(gx - x0), ty = static_cast<float>(gy - y0);
    int xs[4] = {}, ys[4] = {};
    float wx[4] = {}, wy[4] = {};
    for (int k = 0; k < 4; ++k) {
      xs[k] = address(x0 - 1 + k, w, repeat);
      ys[k] = address(y0 - 1 + k, h, repeat);
      wx[k] = catmull_rom(tx, k);
      wy[k] = catmull_rom(ty, k);
    }
    float acc[C] = {};
    for (int b = 0; b < 4; ++b) {
      float row[C] = {};
      for (int a = 0; a < 4; ++a) {
        const uint8_t* p = texel(xs[a], ys[b]);
        for (int c = 0; c < C; ++c) row[c] += wx[a] * static_cast<float>(p[c]);
      }
      for (int c = 0; c < C; ++c) acc[c] += wy[b] * row[c];
    }
    for (int c = 0; c < C; ++c) out[c] = to_byte(acc[c]);
  }

  void sample(Filter f, double gx, double gy, uint8_t* out) const {
    switch (f) {
      case Filter::Nearest: nearest(gx, gy, out); break;
      case Filter::Bilinear: bilinear(gx, gy, out); break;
      case Filter::Bicubic: bicubic(gx, gy, out); break;
    }
  }
};

// ------------------------------------------------------------------------------------------------
// Per-face geometry

/// Affine map from output texel indices (i, j) to input grid coordinates: g = a_i i + a_j j + a_0.
struct GridMap {
  double xi = 0, xj = 0, x0 = 0;
  double yi = 0, yj = 0, y0 = 0;
};

/// Exact copy map in integers: input column = ci i + cj j + c0, input row = ri i + rj j + r0.
struct CopyMap {
  long long ci = 0, cj = 0, c0 = 0, ri = 0, rj = 0, r0 = 0;
};

/// One face as the renderer and the fit read it: built on demand by JobSource::job (a page keeps
/// only its faces' numbers: at 1M faces, a list of these would take 112 MB).
struct FaceJob {
  int face = -1;
  int in_page = -1;
  bool repeat = true;  // the input page's addressing
  std::array<Vec2, 3> out, in;  // texel space, y up
};

/// With repeat addressing a face reads the same texels moved by whole pages: moves it so its lowest
/// corner lies in the first period (u, v in [0, 1)), keeping the numbers small (a chart at u = 37
/// then reads exactly as one at u = 0). Faces already there are not touched. Returns whether the
/// face then lies within that one period (u, v in [0, 1]).
bool shift_into_first_period(std::array<Vec2, 3>& in, const Page& page) {
  const double W = page.width, H = page.height;
  // note: half a texel of slack, so faces of an atlas that reach a hair past its edge (UV rounding
  // in exporters) stay where they are and read as before.
  const auto within = [&] {
    const double t = 0.5;
    for (const Vec2& p : in)
      if (!(p.x() >= -t && p.x() <= W + t && p.y() >= -t && p.y() <= H + t)) return false;
    return true;
  };
  if (within()) return true;
  const double kx = std::floor(std::min({in[0].x(), in[1].x(), in[2].x()}) / W);
  const double ky = std::floor(std::min({in[0].y(), in[1].y(), in[2].y()}) / H);
  for (Vec2& p : in) p -= Vec2(kx * W, ky * H);
  return within();
}

/// Where a face's job comes from: its output triangle from the layout, its input triangle from the
/// mesh (moved into the first period of a repeating page when it lies within one period there).
struct JobSource {
  const TexturedMesh* mesh = nullptr;
  const Atlas* atlas = nullptr;
  const Layout* layout = nullptr;

  FaceJob job(int f) const {
    const size_t fs = static_cast<size_t>(f);
    FaceJob job;
    job.face = f;
    job.in_page = mesh->faces[fs].page;
    const Page& page = mesh->pages[static_cast<size_t>(job.in_page)];
    job.repeat = !page.clamp;
    for (int k = 0; k < 3; ++k) {
      job.out[static_cast<size_t>(k)] = layout->wedge_uv[static_cast<size_t>(atlas->face_wedge[fs][static_cast<size_t>(k)])];
      job.in[static_cast<size_t>(k)] = mesh->corner_texel(fs, k);
    }
    // note: a face within one period samples it with edge clamping, as before: its only reads
    // beyond the page edge are border texels and half-texel bilinear taps, and in an atlas the
    // opposite edge holds an unrelated chart. Only faces that cross the page border wrap.
    if (job.repeat) job.repeat = !shift_into_first_period(job.in, page);
    return job;
  }
};

/// Doubled signed area of output triangle o; `degenerate` when |2 area| <= kDegenerateRatio x its
/// longest edge squared (no interior: rendered as a point/segment, skipped by the fit).
double output_det(const std::array<Vec2, 3>& o, bool& degenerate) {
  const Vec2 e1 = o[1] - o[0], e2 = o[2] - o[0];
  const double det = e1.x() * e2.y() - e1.y() * e2.x();
  const double longest2 = std::max({e1.squaredNorm(), e2.squaredNorm(), (o[2] - o[1]).squaredNorm()});
  degenerate = !(std::abs(det) > kDegenerateRatio * longest2);
  return det;
}

/// Affine map output texel space -> input texel space of a face: in = A out + t.
struct Affine {
  double A00 = 1, A01 = 0, A10 = 0, A11 = 1, t0 = 0, t1 = 0;
};

/// The map taking the output triangle `o` onto the input triangle `a`; det = the output triangle's
/// doubled signed area (must be non-zero).
Affine face_affine(const std::array<Vec2, 3>& o, const std::array<Vec2, 3>& a, double det) {
  const Vec2 e1 = o[1] - o[0], e2 = o[2] - o[0];
  const Vec2 f1 = a[1] - a[0], f2 = a[2] - a[0];
  const double inv = 1.0 / det;
  Affine m;  // A = [f1 f2] [e1 e2]^-1
  m.A00 = (f1.x() * e2.y() - f2.x() * e1.y()) * inv;
  m.A01 = (f2.x() * e1.x() - f1.x() * e2.x()) * inv;
  m.A10 = (f1.y() * e2.y() - f2.y() * e1.y()) * inv;
  m.A11 = (f2.y() * e1.x() - f1.y() * e2.x()) * inv;
  m.t0 = a[0].x() - (m.A00 * o[0].x() + m.A01 * o[0].y());
  m.t1 = a[0].y() - (m.A10 * o[0].x() + m.A11 * o[0].y());
  return m;
}

/// Finds a rotation by a multiple of 90 degrees R and an integer translation t with
/// in_k = R out_k + t for the three corners (within kCopyTolerance). Returns false if none.
bool find_copy_map(const std::array<Vec2, 3>& out, const std::array<Vec2, 3>& in, int in_h, int out_h,
                   CopyMap& map) {
  static const int kRot[4][2][2] = {{{1, 0}, {0, 1}}, {{0, -1}, {1, 0}}, {{-1, 0}, {0, -1}}, {{0, 1}, {-1, 0}}};
  for (const auto& R : kRot) {
    auto apply = [&](const Vec2& p) {
      return Vec2(R[0][0] * p.x() + R[0][1] * p.y(), R[1][0] * p.x() + R[1][1] * p.y());
    };
    const Vec2 t = in[0] - apply(out[0]);
    const double tx = std::round(t.x()), ty = std::round(t.y());
    if (!(std::abs(tx) < 1e9 && std::abs(ty) < 1e9)) continue;
    bool ok = true;
    for (int k = 0; k < 3 && ok; ++k) {
      const Vec2 q = apply(out[static_cast<size_t>(k)]) + Vec2(tx, ty);
      const Vec2& a = in[static_cast<size_t>(k)];
      ok = std::abs(q.x() - a.x()) <= kCopyTolerance && std::abs(q.y() - a.y()) <= kCopyTolerance;
    }
    if (!ok) continue;
    // u = R00 (i + 1/2) + R01 (Ho - j - 1/2) + tx; column = u - 1/2, row = Hi - v - 1/2 (all exact
    // integers: R maps (odd, odd)/2 to (odd, odd)/2).
    const long long Ho = out_h, Hi = in_h, itx = static_cast<long long>(tx), ity = static_cast<long long>(ty);
    map.ci = R[0][0];
    map.cj = -R[0][1];
    map.c0 = (R[0][0] + R[0][1] * (2 * Ho - 1) + 2 * itx - 1) / 2;
    map.ri = -R[1][0];
    map.rj = R[1][1];
    map.r0 = (2 * Hi - 1 - R[1][0] - R[1][1] * (2 * Ho - 1) - 2 * ity) / 2;
    return true;
  }
  return false;
}

/// Closest point of triangle abc to p (Ericson, Real-Time Collision Detection, 5.1.5).
Vec2 closest_on_triangle(const Vec2& p, const Vec2& a, const Vec2& b, const Vec2& c) {
  const Vec2 ab = b - a, ac = c - a, ap = p - a;
  const double d1 = ab.dot(ap), d2 = ac.dot(ap);
  if (d1 <= 0 && d2 <= 0) return a;
  const Vec2 bp = p - b;
  const double d3 = ab.dot(bp), d4 = ac.dot(bp);
  if (d3 >= 0 && d4 <= d3) return b;
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) return a + ab * (d1 / (d1 - d3));
  const Vec2 cp = p - c;
  const double d5 = ab.dot(cp), d6 = ac.dot(cp);
  if (d6 >= 0 && d5 <= d6) return c;
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) return a + ac * (d2 / (d2 - d6));
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0) return b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)));
  const double denom = va + vb + vc;
  if (!(std::abs(denom) > 0)) return a;
  return a + ab * (vb / denom) + ac * (vc / denom);
}

// ------------------------------------------------------------------------------------------------
// Output page canvas

struct Canvas {
  Image* img = nullptr;
  int w = 0, h = 0;
  std::vector<uint8_t> state;  ///< kEmpty/kBorder/kInterior, | kCopied
  /// Border texels: L-inf distance to the triangle that wrote them. Read only where state says
  /// kBorder (written then), so left uninitialised: no 4-byte fill of every texel (120 MB on a 30 MP
  /// page), and pages no border reaches are never touched.
  std::unique_ptr<float[]> dist;

  size_t index(int i, int j) const { return static_cast<size_t>(j) * static_cast<size_t>(w) + static_cast<size_t>(i); }
};

struct PageStats {
  size_t faces_copied = 0, faces_resampled = 0;
};

/// The canvas rows [lo, hi] a face is drawn on (a band of the page, or all of it), and whether the
/// face is counted in PageStats there (in exactly one band: the one holding its first row).
struct RowRange {
  int lo = 0, hi = -1;
  bool count = true;
};

/// The interval [lo, hi] of integers i in [wlo, whi] where pred(i) holds, for pred = "all three
/// edge functions ei[k] i + rk[k] exceed -offset" (up to ties, which pred settles exactly). The
/// roots give the interval to within rounding; its ends are then moved until pred agrees.
/// Returns false when the interval is empty.
template <class Pred>
bool span(const double ei[3], const double rk[3], double offset, int wlo, int whi, const Pred& pred, int& lo, int& hi) {
  double a = wlo, b = whi;
  for (int k = 0; k < 3; ++k) {
    const double c = rk[k] + offset;  // ei i + c > 0
    if (ei[k] > 0) a = std::max(a, std::floor(-c / ei[k]) + 1);
    else if (ei[k] < 0) b = std::min(b, std::ceil(-c / ei[k]) - 1);
    else if (!(c >= 0)) return false;
  }
  const auto clampw = [&](double v) { return static_cast<int>(std::min(std::max(v, static_cast<double>(wlo)), static_cast<double>(whi))); };
  lo = clampw(a);
  hi = clampw(b);
  if (lo > hi) {
    // rounding may have emptied a one-texel interval
    if (pred(lo)) hi = lo;
    else if (pred(hi)) lo = hi;
    else return false;
  }
  while (lo > wlo && pred(lo - 1)) --lo;
  while (lo <= hi && !pred(lo)) ++lo;
  if (lo > hi) return false;
  while (hi < whi && pred(hi + 1)) ++hi;
  while (hi > lo && !pred(hi)) --hi;
  return true;
}

/// A face's texel index window: centres within kBorderRadius of its output bounding box (indices
/// may fall outside the canvas; callers clip them), and the box itself (output texels, y up).
struct TexelWindow {
  double xmin = 0, xmax = 0, ymin = 0, ymax = 0;
  int ilo = 0, ihi = -1, jlo = 0, jhi = -1;

  /// L-infinity distance from the point (cx, cy) to the box; 0 inside.
  double box_dist(double cx, double cy) const { return std::max({xmin - cx, cx - xmax, ymin - cy, cy - ymax, 0.0}); }
};

/// The window of output triangle `o` on a canvas of Wd x Hd texels.
TexelWindow texel_window(const std::array<Vec2, 3>& o, double Wd, double Hd) {
  TexelWindow win;
  win.xmin = std::min({o[0].x(), o[1].x(), o[2].x()});
  win.xmax = std::max({o[0].x(), o[1].x(), o[2].x()});
  win.ymin = std::min({o[0].y(), o[1].y(), o[2].y()});
  win.ymax = std::max({o[0].y(), o[1].y(), o[2].y()});
  const double r = kBorderRadius;
  const auto window = [](double v, double hi) { return std::min(std::max(v, -1.0), hi); };
  win.ilo = static_cast<int>(std::floor(window(win.xmin - r - 0.5, Wd)) + 1);
  win.ihi = static_cast<int>(std::ceil(window(win.xmax + r - 0.5, Wd)) - 1);
  win.jlo = static_cast<int>(std::floor(window(Hd - 0.5 - win.ymax - r, Hd)) + 1);
  win.jhi = static_cast<int>(std::ceil(window(Hd - 0.5 - win.ymin + r, Hd)) - 1);
  return win;
}

/// Renders a degenerate face (a point or a segment: no interior): texels within kBorderRadius of it
/// that no non-degenerate face wrote take the face's own texels when its map is a whole-texel move
/// (find_copy_map on its corners: a zero-area face of an unscaled chart keeps its point's texels
/// exactly), else the colour at the input centroid. Such a texel stores distance 1 + d (d < 1: its
/// L-infinity distance), so any non-degenerate face's border (distance < 1) overwrites it whatever
/// the drawing order, and between degenerate faces the nearer wins. Only rows [rows.lo, rows.hi] are
/// drawn; the face is counted in st when rows.count.
template <int C>
void render_degenerate_face(const FaceJob& job, const Sampler<C>& src, Filter filter, const TexelWindow& win,
                            Canvas& cv, PageStats& st, const RowRange& rows) {
  const auto& o = job.out;
  const double Hd = cv.h;
  const double r = kBorderRadius;
  CopyMap cm;
  const bool copy = find_copy_map(job.out, job.in, src.h, cv.h, cm);
  if (rows.count) (copy ? st.faces_copied : st.faces_resampled)++;
  uint8_t colour[C] = {};
  const Vec2 ci = (job.in[0] + job.in[1] + job.in[2]) / 3.0;
  if (!copy) src.sample(filter, ci.x() - 0.5, src.h - ci.y() - 0.5, colour);
  // Distance test against the longest edge's supporting line plus the bounding box (exact for a
  // segment; a single point has only the box).
  int k0 = 0;
  double best = -1;
  for (int k = 0; k < 3; ++k) {
    const double l2 = (o[static_cast<size_t>((k + 1) % 3)] - o[static_cast<size_t>(k)]).squaredNorm();
    if (l2 > best) { best = l2; k0 = k; }
  }
  const Vec2 a = o[static_cast<size_t>(k0)], d = o[static_cast<size_t>((k0 + 1) % 3)] - a;
  const double nx = -d.y(), ny = d.x(), nl1 = std::abs(nx) + std::abs(ny);
  for (int j = std::max(win.jlo, rows.lo); j <= std::min(win.jhi, rows.hi); ++j) {
    const double cy = Hd - j - 0.5;
    for (int i = std::max(win.ilo, 0); i <= std::min(win.ihi, cv.w - 1); ++i) {
      const double cx = i + 0.5;
      double dd = win.box_dist(cx, cy);
      if (nl1 > 0) dd = std::max(dd, std::abs(nx * (cx - a.x()) + ny * (cy - a.y())) / nl1);
      if (!(dd < r)) continue;
      const size_t idx = cv.index(i, j);
      const uint8_t s = cv.state[idx] & kCoverMask;
      if (s == kInterior || (s == kBorder && cv.dist[idx] <= r + dd)) continue;
      cv.state[idx] = static_cast<uint8_t>(kBorder | (copy ? kCopied : 0));
      cv.dist[idx] = static_cast<float>(r + dd);
      if (copy) std::memcpy(cv.img->at(i, j), src.texel_at(cm.ci * i + cm.cj * j + cm.c0, cm.ri * i + cm.rj * j + cm.r0), C);
      else std::memcpy(cv.img->at(i, j), colour, C);
    }
  }
}

/// Edge functions of a non-degenerate output triangle, oriented so the interior is positive,
/// normalised by the L1 norm of the normal so -E is the L-infinity distance to the edge's line;
/// written in texel indices: E_k(i, j) = ei[k] i + ej[k] j + e0[k] with centre (i + 0.5, H - j - 0.5).
/// tie[k]: texel centres exactly on edge k belong to this triangle (top-left rule).
struct EdgeFunctions {
  double ei[3], ej[3], e0[3];
  bool tie[3];
};

/// The edge functions of `o` (doubled signed area det != 0) on a canvas Hd texels high.
EdgeFunctions edge_functions(const std::array<Vec2, 3>& o, double det, double Hd) {
  EdgeFunctions ef;
  const double sgn = det > 0 ? 1.0 : -1.0;
  for (int k = 0; k < 3; ++k) {
    const Vec2& v = o[static_cast<size_t>(k)];
    const Vec2 e = o[static_cast<size_t>((k + 1) % 3)] - v;
    double nx = -e.y() * sgn, ny = e.x() * sgn;
    const double l1 = std::abs(nx) + std::abs(ny);
    nx /= l1;
    ny /= l1;
    const double c = -(nx * v.x() + ny * v.y());
    ef.ei[k] = nx;
    ef.ej[k] = -ny;
    ef.e0[k] = nx * 0.5 + ny * (Hd - 0.5) + c;
    // note: of two triangles sharing an edge exactly one owns texel centres on it (top-left rule).
    ef.tie[k] = nx > 0 || (nx == 0 && ny > 0);
  }
  return ef;
}

/// Where a non-degenerate face's texels take their colour: the affine map output -> input texel
/// space (`af`, and `g` in texel indices of both pages), whether texels outside the triangle may
/// extrapolate it (stretch <= kMaxExtrapolationStretch), and the exact integer copy map when the
/// face is an unscaled translation, quarter turn or mirror of its input (`copy`).
struct FaceMapping {
  Affine af;
  GridMap g;
  bool extrapolate = false;
  CopyMap cm;
  bool copy = false;
};

/// The mapping of `job` (doubled signed output area det != 0) from an input page src_h texels high
/// to a canvas Hd texels high.
FaceMapping face_mapping(const FaceJob& job, double det, int src_h, int canvas_h) {
  FaceMapping m;
  const double Hd = canvas_h;
  // Affine map output texel space -> input texel space: in = A out + t.
  m.af = face_affine(job.out, job.in, det);
  const double A00 = m.af.A00, A01 = m.af.A01, A10 = m.af.A10, A11 = m.af.A11, t0 = m.af.t0, t1 = m.af.t1;
  const double Hi = src_h;
  m.g.xi = A00;
  m.g.xj = -A01;
  m.g.x0 = A00 * 0.5 + A01 * (Hd - 0.5) + t0 - 0.5;
  m.g.yi = -A10;
  m.g.yj = A11;
  m.g.y0 = Hi - 0.5 - (A10 * 0.5 + A11 * (Hd - 0.5) + t1);
  // Largest singular value of A (stretch), from the Frobenius norm and determinant.
  const double fro2 = A00 * A00 + A01 * A01 + A10 * A10 + A11 * A11, dA = A00 * A11 - A01 * A10;
  const double stretch = std::sqrt(0.5 * (fro2 + std::sqrt(std::max(fro2 * fro2 - 4 * dA * dA, 0.0))));
  m.extrapolate = stretch <= kMaxExtrapolationStretch;
  m.copy = find_copy_map(job.out, job.in, src_h, canvas_h, m.cm);
  return m;
}

/// Renders row j of a non-degenerate face on the canvas, within texel columns [wlo, whi]:
/// interior texels (centre inside, top-left tie rule) always; border texels (centre within
/// kBorderRadius) only where no interior texel is and no other triangle is nearer.
template <int C>
void render_face_row(int j, int wlo, int whi, const FaceJob& job, const Sampler<C>& src, Filter filter,
                     const TexelWindow& win, const EdgeFunctions& ef, const FaceMapping& m, Canvas& cv) {
  const auto& o = job.out;
  const double Hd = cv.h;
  const double r = kBorderRadius;
  const double A00 = m.af.A00, A01 = m.af.A01, A10 = m.af.A10, A11 = m.af.A11, t0 = m.af.t0, t1 = m.af.t1;
  const double Hi = src.h;
  const GridMap& g = m.g;
  const CopyMap& cm = m.cm;
  const bool copy = m.copy;
  const uint8_t written_state_bits = copy ? kCopied : 0;
  const double rk[3] = {ef.ej[0] * j + ef.e0[0], ef.ej[1] * j + ef.e0[1], ef.ej[2] * j + ef.e0[2]};
  const auto E = [&](int k, int i) { return ef.ei[k] * i + rk[k]; };
  const auto inside = [&](int i) {
    for (int k = 0; k < 3; ++k) {
      const double e = E(k, i);
      if (!(e > 0 || (e == 0 && ef.tie[k]))) return false;
    }
    return true;
  };
  const auto near = [&](int i) { return E(0, i) > -r && E(1, i) > -r && E(2, i) > -r; };
  int blo = wlo, bhi = whi, ilo_row = wlo, ihi_row = whi;
  if (!span(ef.ei, rk, r, wlo, whi, near, blo, bhi)) return;
  const bool has_interior = span(ef.ei, rk, 0.0, blo, bhi, inside, ilo_row, ihi_row);
  if (!has_interior) {
    ilo_row = bhi + 1;
    ihi_row = bhi;
  }
  const double cy = Hd - j - 0.5;
  uint8_t* row_px = cv.img->at(0, j);
  uint8_t* row_state = &cv.state[cv.index(0, j)];
  float* row_dist = &cv.dist[cv.index(0, j)];
  const auto border = [&](int i) {
    const uint8_t s = row_state[i] & kCoverMask;
    if (s == kInterior) return;
    const double dd = std::max(std::max(std::max(-E(0, i), -E(1, i)), std::max(-E(2, i), 0.0)), win.box_dist(i + 0.5, cy));
    if (!(dd < r) || (s == kBorder && row_dist[i] <= dd)) return;
    row_state[i] = static_cast<uint8_t>(kBorder | written_state_bits);
    row_dist[i] = static_cast<float>(dd);
    uint8_t* dst = row_px + static_cast<size_t>(i) * C;
    if (copy) {
      std::memcpy(dst, src.texel_at(cm.ci * i + cm.cj * j + cm.c0, cm.ri * i + cm.rj * j + cm.r0), C);
    } else if (m.extrapolate) {
      src.sample(filter, g.xi * i + g.xj * j + g.x0, g.yi * i + g.yj * j + g.y0, dst);
    } else {
      const Vec2 p = closest_on_triangle(Vec2(i + 0.5, cy), o[0], o[1], o[2]);
      const double u = A00 * p.x() + A01 * p.y() + t0, v = A10 * p.x() + A11 * p.y() + t1;
      src.sample(filter, u - 0.5, Hi - v - 0.5, dst);
    }
  };
  for (int i = blo; i < ilo_row; ++i) border(i);
  if (ilo_row <= ihi_row) {
    std::memset(row_state + ilo_row, kInterior | written_state_bits, static_cast<size_t>(ihi_row - ilo_row + 1));
    if (copy) {
      const long long cj = cm.cj * j + cm.c0, rj = cm.rj * j + cm.r0;
      for (int i = ilo_row; i <= ihi_row; ++i)
        std::memcpy(row_px + static_cast<size_t>(i) * C, src.texel_at(cm.ci * i + cj, cm.ri * i + rj), C);
    } else {
      const double gx = g.xj * j + g.x0, gy = g.yj * j + g.y0;
      switch (filter) {
        case Filter::Nearest:
          for (int i = ilo_row; i <= ihi_row; ++i) src.nearest(g.xi * i + gx, g.yi * i + gy, row_px + static_cast<size_t>(i) * C);
          break;
        case Filter::Bilinear:
          for (int i = ilo_row; i <= ihi_row; ++i) src.bilinear(g.xi * i + gx, g.yi * i + gy, row_px + static_cast<size_t>(i) * C);
          break;
        case Filter::Bicubic:
          for (int i = ilo_row; i <= ihi_row; ++i) src.bicubic(g.xi * i + gx, g.yi * i + gy, row_px + static_cast<size_t>(i) * C);
          break;
      }
    }
  }
  for (int i = std::max(ihi_row + 1, blo); i <= bhi; ++i) border(i);
}

/// Rasterises one face on the canvas rows `rows`. Interior texels (centre inside, top-left tie rule) are
/// always written; border texels (centre within kBorderRadius) only where no interior texel is and
/// no other triangle is nearer. A texel's value depends only on the faces drawn on it before, in
/// order: the rows of a page can be drawn in bands side by side (render_page_jobs).
template <int C>
void render_face(const FaceJob& job, const Sampler<C>& src, Filter filter, Canvas& cv, PageStats& st,
                 const RowRange& rows) {
  bool degenerate = false;
  const double det = output_det(job.out, degenerate);
  const TexelWindow win = texel_window(job.out, cv.w, cv.h);
  if (degenerate) {
    render_degenerate_face(job, src, filter, win, cv, st, rows);
    return;
  }
  const EdgeFunctions ef = edge_functions(job.out, det, cv.h);
  const FaceMapping m = face_mapping(job, det, src.h, cv.h);
  if (rows.count) (m.copy ? st.faces_copied : st.faces_resampled)++;
  // Along a row every edge function is monotone in i, so both the interior and the border are
  // intervals: render_face_row finds them from the roots, then settles their ends with the exact
  // predicates.
  const int wlo = std::max(win.ilo, 0), whi = std::min(win.ihi, cv.w - 1);
  for (int j = std::max(win.jlo, rows.lo); j <= std::min(win.jhi, rows.hi); ++j)
    render_face_row(j, wlo, whi, job, src, filter, win, ef, m, cv);
}

// ------------------------------------------------------------------------------------------------
// Least-squares texel fit (TexelFit::LeastSquares)
//
// A renderer (and eval's fidelity measure) reads the output page bilinearly. Sampling the input at
// each texel centre and reading the result bilinearly again filters twice; instead, the texels of
// resampled faces are chosen so that the bilinear reconstruction of the output page matches the
// bilinear reconstruction of the input page seen through the face maps, in least squares over every
// output triangle (the L2 projection onto the bilinear basis; cf. Blu, Thevenaz, Unser, "Linear
// interpolation revitalized", IEEE TIP 2004). Quadrature: 2 x 2 Gauss-Legendre points in every cell
// between four texel centres (exact for the output side, a polynomial of degree 2 per axis). Copied
// texels stay fixed; a small Tikhonov term keeps barely seen texels (chart borders) near their
// sampled value. Solved by Jacobi-preconditioned conjugate gradients on the fitted texels only.

/// Gauss-Legendre abscissae of [0, 1], 2 points.
constexpr double kGauss[2] = {0.21132486540518713, 0.78867513459481287};
/// Tikhonov weight towards the sampled value, relative to a fully covered texel's weight (16/9).
constexpr float kFitRegularisation = 0.02f;


/// Sum over the samples present in `mask` (bit 2b + a: Gauss point (a, b) of the cell) of w w^T,
/// w = bilinear weights of the cell's corners (index 2 dy + dx).
std::array<float, 16> cell_matrix(int mask) {
  std::array<float, 16> M{};
  for (int b = 0; b < 2; ++b)
    for (int a = 0; a < 2; ++a) {
      if (!(mask & (1 << (2 * b + a)))) continue;
      const double wx[2] = {1 - kGauss[a], kGauss[a]}, wy[2] = {1 - kGauss[b], kGauss[b]};
      double w[4];
      for (int k = 0; k < 4; ++k) w[k] = wx[k & 1] * wy[k >> 1];
      for (int k = 0; k < 4; ++k)
        for (int l = 0; l < 4; ++l) M[static_cast<size_t>(4 * k + l)] += static_cast<float>(w[k] * w[l]);
    }
  return M;
}

/// Texels per side of the windows the fit is solved in: each window's fitted texels are the
/// unknowns, every texel outside it keeps its current value (windows are solved in raster order,
/// so a window sees its fitted predecessors). Bounds the fit's memory (about 60 bytes per texel of
/// a window) whatever the page size. 256, not larger: windows of one wavefront run in parallel,
/// and a real tile's single page of 2-4 MP holds only 2 x 2 windows of 1024 (one window per
/// wavefront: no parallelism), but 8 x 8 of 256 (up to 4 per wavefront). Measured on three real
/// tiles (2026-12-02, docs/speed.md): texture PSNR within 0.001 dB of 1024-texel windows.
constexpr int kFitWindow = 256;

/// The unknowns of one fit window [X0, X1) x [Y0, Y1) (texel indices, row 0 at the top): the
/// texels written by a resampled face (interior or border) and not copied, numbered in raster order.
struct FitUnknowns {
  int X0 = 0, Y0 = 0, X1 = 0, Y1 = 0;
  std::vector<int> uid;         ///< per texel of the window: its unknown's number, or -1 (fixed)
  std::vector<size_t> texel_of; ///< per unknown: its texel's index on the canvas

  /// The unknown's number of texel (x, y) of the page; -1 when fixed or outside the window.
  int at(int x, int y) const {
    return x < X0 || x >= X1 || y < Y0 || y >= Y1
               ? -1
               : uid[static_cast<size_t>(y - Y0) * static_cast<size_t>(X1 - X0) + static_cast<size_t>(x - X0)];
  }
};

/// The fitted texels of window [X0, X1) x [Y0, Y1) of the canvas.
FitUnknowns collect_unknowns(const Canvas& cv, int X0, int Y0, int X1, int Y1) {
  FitUnknowns u;
  u.X0 = X0;
  u.Y0 = Y0;
  u.X1 = X1;
  u.Y1 = Y1;
  const int ww = X1 - X0, wh = Y1 - Y0;
  u.uid.assign(static_cast<size_t>(ww) * static_cast<size_t>(wh), -1);
  for (int y = Y0; y < Y1; ++y)
    for (int x = X0; x < X1; ++x) {
      const size_t t = cv.index(x, y);
      if ((cv.state[t] & kCoverMask) && !(cv.state[t] & kCopied)) {
        u.uid[static_cast<size_t>(y - Y0) * static_cast<size_t>(ww) + static_cast<size_t>(x - X0)] = static_cast<int>(u.texel_of.size());
        u.texel_of.push_back(t);
      }
    }
  return u;
}

/// The cells of a fit window. Cell (m, q) spans grid [m, m+1] x [q, q+1] (grid: texel centres at
/// integers, row index downwards); its corners clamp to the page (clamp-to-edge reads). The
/// window's cells are those with a corner in it: m in [X0-1, X1-1], q in [Y0-1, Y1-1], within
/// [-1, W-1] x [-1, H-1]. mask: per cell, the Gauss points (bit 2b + a) some face covers.
struct FitCells {
  int W = 0, H = 0;
  long long cm0 = 0, cm1 = 0, cq0 = 0, cq1 = 0;
  size_t cw = 0;
  std::vector<uint8_t> mask;

  FitCells(int w, int h, int X0, int Y0, int X1, int Y1) : W(w), H(h) {
    cm0 = std::max(X0 - 1, -1);
    cm1 = std::min(X1 - 1, W - 1);
    cq0 = std::max(Y0 - 1, -1);
    cq1 = std::min(Y1 - 1, H - 1);
    cw = static_cast<size_t>(cm1 - cm0 + 1);
    mask.assign(cw * static_cast<size_t>(cq1 - cq0 + 1), 0);
  }
  /// Texel of corner k (index 2 dy + dx) of cell (m, q), clamped to the page.
  void corner_xy(long long m, long long q, int k, int& x, int& y) const {
    x = clampi(m + (k & 1), W - 1);
    y = clampi(q + (k >> 1), H - 1);
  }
};

/// Narrows [mlo, mhi] to the cells of row q (grid y in [q, q + 1]) whose Gauss points can lie in
/// the triangle g (grid coordinates): the x-range where the triangle meets the row's two Gauss
/// lines, widened by one cell on each side, so rounding never drops a cell whose point the exact
/// inside test accepts (cells outside the range have no point inside: skipping them changes
/// nothing). Returns false when no cell remains.
bool row_cells(const std::array<Vec2, 3>& g, double q, long long& mlo, long long& mhi) {
  double xl = std::numeric_limits<double>::infinity(), xr = -xl;
  for (const double gy : kGauss) {
    const double py = q + gy;
    for (int k = 0; k < 3; ++k) {
      const Vec2& a = g[static_cast<size_t>(k)];
      const Vec2& b = g[static_cast<size_t>((k + 1) % 3)];
      // note: a tolerance in y too: the inside test may accept a point a rounding error outside.
      if (py < std::min(a.y(), b.y()) - 1e-6 || py > std::max(a.y(), b.y()) + 1e-6) continue;
      const double dy = b.y() - a.y();
      const double t = dy == 0 ? 0 : std::clamp((py - a.y()) / dy, 0.0, 1.0);
      const double x = a.x() + t * (b.x() - a.x());
      xl = std::min({xl, x, dy == 0 ? b.x() : x});
      xr = std::max({xr, x, dy == 0 ? b.x() : x});
    }
  }
  if (!(xl <= xr)) return false;
  // Gauss point m + kGauss[a] in [xl, xr]  =>  m in [xl - kGauss[1], xr - kGauss[0]].
  mlo = std::max(mlo, static_cast<long long>(std::floor(xl - kGauss[1])) - 1);
  mhi = std::min(mhi, static_cast<long long>(std::floor(xr - kGauss[0])) + 1);
  return mlo <= mhi;
}

/// The point-in-face test of add_face_to_rhs: (px, py) is inside face g when, for each edge (a, b)
/// of g, sgn ((b - a).x (py - a.y) - (b - a).y (px - a.x)) >= 0. The parts that depend on the row
/// (py) or the column (px) alone are computed once per row or cell; each point's value is the one
/// of the whole expression (same operations on the same operands).
struct InsideTest {
  double ax[3], ay[3], ex[3], ey[3], sgn;

  InsideTest(const std::array<Vec2, 3>& g, double orientation) : sgn(orientation) {
    for (size_t k = 0; k < 3; ++k) {
      const Vec2& a = g[k];
      const Vec2& b = g[(k + 1) % 3];
      ax[k] = a.x();
      ay[k] = a.y();
      ex[k] = b.x() - a.x();
      ey[k] = b.y() - a.y();
    }
  }
  /// The row parts at py: (b - a).x (py - a.y) per edge.
  void row(double py, double t[3]) const {
    for (int k = 0; k < 3; ++k) t[k] = ex[k] * (py - ay[k]);
  }
  /// The column parts at px: (b - a).y (px - a.x) per edge.
  void column(double px, double t[3]) const {
    for (int k = 0; k < 3; ++k) t[k] = ey[k] * (px - ax[k]);
  }
  bool at(const double ty[3], const double tx[3]) const {
    for (int k = 0; k < 3; ++k)
      if (sgn * (ty[k] - tx[k]) < 0) return false;
    return true;
  }
};

/// weights[2 b + a][k]: the bilinear weight of a cell's corner k (2 dy + dx) at its Gauss point
/// (a, b), as float.
const std::array<std::array<float, 4>, 4>& gauss_weights() {
  static const std::array<std::array<float, 4>, 4> w = [] {
    std::array<std::array<float, 4>, 4> t{};
    for (int b = 0; b < 2; ++b)
      for (int a = 0; a < 2; ++a) {
        const double wx[2] = {1 - kGauss[a], kGauss[a]}, wy[2] = {1 - kGauss[b], kGauss[b]};
        for (int k = 0; k < 4; ++k)
          t[static_cast<size_t>(2 * b + a)][static_cast<size_t>(k)] = static_cast<float>(wx[k & 1] * wy[k >> 1]);
      }
    return t;
  }();
  return w;
}

/// Adds face `job`'s share of the fit's right-hand side: at each Gauss point of the window's cells
/// inside the face (and not yet taken by an earlier face: the point's bit in cells.mask), the input
/// read bilinearly through the face map, weighted by the bilinear weights of the cell's unknown
/// corners. Degenerate faces and faces missing the window add nothing.
template <int C>
void add_face_to_rhs(const FaceJob& job, const std::vector<const Image*>& inputs, const FitUnknowns& unknowns,
                     FitCells& cells, std::vector<Lanes>& rhs) {
  const int H = cells.H;
  const auto& o = job.out;
  // Corners in grid coordinates; skip faces whose box misses the window's cells.
  std::array<Vec2, 3> g;
  for (int k = 0; k < 3; ++k) g[static_cast<size_t>(k)] = Vec2(o[static_cast<size_t>(k)].x() - 0.5, H - o[static_cast<size_t>(k)].y() - 0.5);
  const double gxmin = std::min({g[0].x(), g[1].x(), g[2].x()}), gxmax = std::max({g[0].x(), g[1].x(), g[2].x()});
  const double gymin = std::min({g[0].y(), g[1].y(), g[2].y()}), gymax = std::max({g[0].y(), g[1].y(), g[2].y()});
  const long long m0 = std::max<long long>(cells.cm0, static_cast<long long>(std::floor(gxmin)));
  const long long m1 = std::min<long long>(cells.cm1, static_cast<long long>(std::floor(gxmax)));
  const long long q0 = std::max<long long>(cells.cq0, static_cast<long long>(std::floor(gymin)));
  const long long q1 = std::min<long long>(cells.cq1, static_cast<long long>(std::floor(gymax)));
  if (m0 > m1 || q0 > q1) return;
  bool degenerate = false;
  const double det = output_det(o, degenerate);
  if (degenerate) return;
  const Affine af = face_affine(o, job.in, det);
  const Image& in = *inputs[static_cast<size_t>(job.in_page)];
  Sampler<C> src;
  src.px = in.pixels.data();
  src.w = in.width;
  src.h = in.height;
  src.repeat = job.repeat;
  const InsideTest inside(g, det > 0 ? -1.0 : 1.0);  // the y flip reverses the orientation
  const std::array<std::array<float, 4>, 4>& weights = gauss_weights();
  const double Hi = in.height;
  for (long long q = q0; q <= q1; ++q) {
    long long mlo = m0, mhi = m1;
    if (!row_cells(g, static_cast<double>(q), mlo, mhi)) continue;
    double ty[2][3];
    for (int b = 0; b < 2; ++b) inside.row(static_cast<double>(q) + kGauss[b], ty[b]);
    for (long long m = mlo; m <= mhi; ++m) {
      int ids[4];
      bool touches = false;
      for (int k = 0; k < 4; ++k) {
        int x, y;
        cells.corner_xy(m, q, k, x, y);
        ids[k] = unknowns.at(x, y);
        touches = touches || ids[k] >= 0;
      }
      if (!touches) continue;
      uint8_t& cm = cells.mask[static_cast<size_t>(q - cells.cq0) * cells.cw + static_cast<size_t>(m - cells.cm0)];
      if (cm == 15) continue;  // every point taken by earlier faces
      double tx[2][3];
      for (int a = 0; a < 2; ++a) inside.column(static_cast<double>(m) + kGauss[a], tx[a]);
      for (int b = 0; b < 2; ++b)
        for (int a = 0; a < 2; ++a) {
          const int bit = 1 << (2 * b + a);
          const double px = static_cast<double>(m) + kGauss[a], py = static_cast<double>(q) + kGauss[b];
          if ((cm & bit) || !inside.at(ty[b], tx[a])) continue;
          cm = static_cast<uint8_t>(cm | bit);
          const double ox = px + 0.5, oy = H - py - 0.5;
          const double u = af.A00 * ox + af.A01 * oy + af.t0, v = af.A10 * ox + af.A11 * oy + af.t1;
          const Lanes t = src.bilinear_lanes(u - 0.5, Hi - v - 0.5);
          for (int k = 0; k < 4; ++k)
            if (ids[k] >= 0) rhs[static_cast<size_t>(ids[k])] += weights[static_cast<size_t>(2 * b + a)][static_cast<size_t>(k)] * t;
        }
    }
  }
}

/// The fit's normal matrix K = sum over active cells of G^T M G + lambda I, on the fitted texels.
/// Its vectors (x, right-hand side, CG's) hold U + 1 Lanes: entry U is the fixed corners' slot,
/// zero in the vectors K is applied to (x, p), and what K adds there is never read.
struct FitSystem {
  struct Cell {
    int id[4];     ///< corner unknowns (U: a fixed texel)
    uint8_t mask;  ///< Gauss points covered: selects the cell's matrix
  };
  std::array<std::array<float, 16>, 16> mats;  ///< cell_matrix of every mask
  std::array<std::array<Lanes, 16>, 16> lane_mats;  ///< mats, each entry in every lane
  std::vector<Cell> cells;
  std::vector<float> diag;  ///< K's diagonal (the Jacobi preconditioner), U entries
  float lambda = 0;
  size_t unknowns = 0;  ///< U

  /// out = K v (U + 1 entries each; v[U] is 0). Per unknown, the cells' shares are added in cell
  /// order and corner order, as the channel-by-channel code did; a fixed corner reads v[U] (0) and
  /// its share goes to out[U] instead of being skipped.
  void apply(const std::vector<Lanes>& v, std::vector<Lanes>& out) const {
    for (size_t u = 0; u < unknowns; ++u) out[u] = lambda * v[u];
    for (const Cell& cell : cells) {
      const std::array<Lanes, 16>& M = lane_mats[cell.mask];
      const Lanes loc[4] = {v[static_cast<size_t>(cell.id[0])], v[static_cast<size_t>(cell.id[1])],
                            v[static_cast<size_t>(cell.id[2])], v[static_cast<size_t>(cell.id[3])]};
      for (int k = 0; k < 4; ++k) {
        Lanes acc = {};
        for (int l = 0; l < 4; ++l) acc += M[static_cast<size_t>(4 * k + l)] * loc[l];
        out[static_cast<size_t>(cell.id[k])] += acc;
      }
    }
  }
};

/// Builds the system of the window's active cells: each cell's corner unknowns and matrix, K's
/// diagonal, and the fixed corners' share moved to the right-hand side (rhs -= M f).
template <int C>
FitSystem assemble_system(const Canvas& cv, const FitUnknowns& unknowns, const FitCells& cells, std::vector<Lanes>& rhs) {
  FitSystem sys;
  for (size_t mask = 0; mask < 16; ++mask) {
    sys.mats[mask] = cell_matrix(static_cast<int>(mask));
    for (size_t i = 0; i < 16; ++i) sys.lane_mats[mask][i] = Lanes{} + sys.mats[mask][i];
  }
  sys.unknowns = unknowns.texel_of.size();
  sys.diag.assign(sys.unknowns, 0.f);
  sys.cells.reserve(cells.mask.size() - static_cast<size_t>(std::count(cells.mask.begin(), cells.mask.end(), 0)));
  const uint8_t* px = cv.img->pixels.data();
  for (size_t ci = 0; ci < cells.mask.size(); ++ci) {
    if (!cells.mask[ci]) continue;
    const long long m = static_cast<long long>(ci % cells.cw) + cells.cm0, q = static_cast<long long>(ci / cells.cw) + cells.cq0;
    FitSystem::Cell cell;
    cell.mask = cells.mask[ci];
    size_t cidx[4];
    int id[4];
    for (int k = 0; k < 4; ++k) {
      int x, y;
      cells.corner_xy(m, q, k, x, y);
      cidx[k] = cv.index(x, y);
      id[k] = unknowns.at(x, y);
      cell.id[k] = id[k] >= 0 ? id[k] : static_cast<int>(sys.unknowns);
    }
    const std::array<float, 16>& M = sys.mats[cell.mask];
    for (int k = 0; k < 4; ++k) {
      if (id[k] < 0) continue;
      for (int l = 0; l < 4; ++l) {
        const float mkl = M[static_cast<size_t>(4 * k + l)];
        if (id[l] == id[k]) sys.diag[static_cast<size_t>(id[k])] += mkl;
        if (id[l] >= 0) continue;
        rhs[static_cast<size_t>(id[k])] -= mkl * texel_lanes<C>(px + cidx[l] * C);
      }
    }
    sys.cells.push_back(cell);
  }
  return sys;
}

/// The sum over the first n entries of a and b, lanes below C, of a b in double, in the order of
/// the channel-by-channel vectors (entry, then lane).
template <int C>
double dot(const std::vector<Lanes>& a, const std::vector<Lanes>& b, size_t n) {
  double s = 0;
  for (size_t u = 0; u < n; ++u)
    for (int c = 0; c < C; ++c) s += static_cast<double>(a[u][c]) * b[u][c];
  return s;
}

/// Solves K x = rhs by Jacobi-preconditioned conjugate gradients from the start value x, for at
/// most `iterations` steps or until the residual's norm falls to 1e-4 of its start. rhs is used
/// as the residual (its content is lost). x and rhs: U + 1 entries, x[U] = 0.
template <int C>
void solve_fit(const FitSystem& sys, std::vector<Lanes>& rhs, std::vector<Lanes>& x, int iterations) {
  const size_t U = sys.unknowns;
  const std::vector<float>& diag = sys.diag;
  std::vector<Lanes>& r = rhs;
  std::vector<Lanes> p(U + 1, Lanes{}), Kp(U + 1);  // p[U] stays 0
  sys.apply(x, Kp);
  for (size_t u = 0; u < U; ++u) {
    r[u] -= Kp[u];
    p[u] = r[u] / diag[u];
  }
  double rz = dot<C>(r, p, U);
  const double r0 = dot<C>(r, r, U);
  for (int it = 0; it < iterations && rz > 0; ++it) {
    sys.apply(p, Kp);
    const double pKp = dot<C>(p, Kp, U);
    if (!(pKp > 0)) break;
    const float alpha = static_cast<float>(rz / pKp);
    double rz_new = 0, rr = 0;
    for (size_t u = 0; u < U; ++u) {
      x[u] += alpha * p[u];
      r[u] -= alpha * Kp[u];
      const Lanes z = r[u] / diag[u];
      for (int c = 0; c < C; ++c) {
        rz_new += static_cast<double>(r[u][c]) * z[c];
        rr += static_cast<double>(r[u][c]) * r[u][c];
      }
    }
    if (rr <= 1e-8 * r0) break;
    const float beta = static_cast<float>(rz_new / rz);
    rz = rz_new;
    for (size_t u = 0; u < U; ++u) p[u] = r[u] / diag[u] + beta * p[u];
  }
}

/// A fit window's part that does not depend on other windows' fitted texels: its unknowns, its
/// cells' masks and its right-hand side from the faces (prepare_window), kept for its solve.
struct PreparedWindow {
  FitUnknowns unknowns;
  FitCells cells;
  std::vector<Lanes> rhs;  ///< U + 1 entries (empty when U = 0)
};

/// Prepares the fit of the window [X0, X1) x [Y0, Y1) (texel indices, row 0 at the top): reads the
/// canvas's state and the input pages only, never a texel a window's solve writes. `faces`: the
/// page's faces (in face order) whose box may reach the window's cells (others add nothing).
template <int C>
std::unique_ptr<PreparedWindow> prepare_window(const std::vector<int>& faces, const JobSource& source,
                                               const std::vector<const Image*>& inputs, const Canvas& cv, int X0,
                                               int Y0, int X1, int Y1) {
  std::unique_ptr<PreparedWindow> w(
      new PreparedWindow{collect_unknowns(cv, X0, Y0, X1, Y1), FitCells(cv.w, cv.h, X0, Y0, X1, Y1), {}});
  const size_t U = w->unknowns.texel_of.size();
  if (U == 0) return w;
  w->rhs.assign(U + 1, Lanes{});
  for (const int f : faces) add_face_to_rhs<C>(source.job(f), inputs, w->unknowns, w->cells, w->rhs);
  return w;
}

/// Solves a prepared window's fit and writes its texels; reads the texels of a ring one texel wide
/// around it (fitted or not: see fit_least_squares). Returns the number of texels fitted.
template <int C>
size_t solve_window(PreparedWindow& w, int iterations, Canvas& cv) {
  const FitUnknowns& unknowns = w.unknowns;
  const size_t U = unknowns.texel_of.size();
  if (U == 0) return 0;
  std::vector<Lanes>& rhs = w.rhs;
  // Fixed corners move to the right-hand side; the Tikhonov term pulls towards the sampled value.
  FitSystem sys = assemble_system<C>(cv, unknowns, w.cells, rhs);
  w.cells.mask = std::vector<uint8_t>();
  sys.lambda = kFitRegularisation * 16.f / 9.f;
  const uint8_t* px = cv.img->pixels.data();
  std::vector<Lanes> x(U + 1, Lanes{});
  for (size_t u = 0; u < U; ++u) {
    x[u] = texel_lanes<C>(px + unknowns.texel_of[u] * C);
    rhs[u] += sys.lambda * x[u];
  }
  for (float& d : sys.diag) d += sys.lambda;
  solve_fit<C>(sys, rhs, x, iterations);
  uint8_t* out = cv.img->pixels.data();
  for (size_t u = 0; u < U; ++u)
    for (int c = 0; c < C; ++c) out[unknowns.texel_of[u] * C + static_cast<size_t>(c)] = to_byte(x[u][c]);
  return U;
}

/// The order of the fit's work on several threads. Window w = i nx + j (row i, column j) is first
/// prepared (in raster order, at most `ahead` windows past the lowest unsolved one), then solved
/// once it is prepared and (i, j-1) and (i-1, min(j+1, nx-1)) are solved (see fit_least_squares).
/// Solves go first (they are the chain); a worker waits only while no task is ready and another
/// worker runs one, so the lowest unsolved window is always prepared or next to be prepared.
class FitSchedule {
 public:
  struct Task {
    bool solve = false;
    size_t window = 0;
  };

  FitSchedule(int nx, int ny, size_t ahead)
      : nx_(static_cast<size_t>(nx)), n_(static_cast<size_t>(nx) * static_cast<size_t>(ny)), ahead_(ahead),
        state_(n_, kNew) {}

  /// The next task; false when every window is solved or a task failed.
  bool next(Task& t) {
    std::unique_lock<std::mutex> lock(m_);
    for (;;) {
      if (failed_ || first_unsolved_ == n_) return false;
      for (size_t w = first_unsolved_; w < next_prepare_; ++w)
        if (state_[w] == kPrepared && ready(w)) {
          state_[w] = kRunning;
          t = {true, w};
          return true;
        }
      if (next_prepare_ < n_ && next_prepare_ - first_unsolved_ < ahead_) {
        t = {false, next_prepare_++};
        return true;
      }
      cv_.wait(lock);
    }
  }
  /// Task t has finished.
  void done(const Task& t) {
    std::lock_guard<std::mutex> lock(m_);
    state_[t.window] = t.solve ? kSolved : kPrepared;
    while (first_unsolved_ < n_ && state_[first_unsolved_] == kSolved) ++first_unsolved_;
    cv_.notify_all();
  }
  /// A task threw: the other workers stop.
  void fail() {
    std::lock_guard<std::mutex> lock(m_);
    failed_ = true;
    cv_.notify_all();
  }

 private:
  enum State : uint8_t { kNew, kPrepared, kRunning, kSolved };
  bool ready(size_t w) const {
    const size_t i = w / nx_, j = w % nx_;
    return (j == 0 || state_[w - 1] == kSolved) && (i == 0 || state_[(i - 1) * nx_ + std::min(j + 1, nx_ - 1)] == kSolved);
  }
  size_t nx_, n_, ahead_;
  std::vector<State> state_;
  size_t first_unsolved_ = 0, next_prepare_ = 0;
  bool failed_ = false;
  std::mutex m_;
  std::condition_variable cv_;
};

/// The page's faces (in face order) whose grid box may reach the cells of each fit window (index
/// row * nx + column): a superset of the faces that add to the window's right-hand side (the test in
/// add_face_to_rhs is exact), without degenerate faces (which add nothing). Each window then visits
/// its own faces instead of all the page's.
std::vector<std::vector<int>> window_faces(const std::vector<int>& faces, const JobSource& source, int H, int nx,
                                           int ny) {
  std::vector<std::vector<int>> out(static_cast<size_t>(nx) * static_cast<size_t>(ny));
  const double K = kFitWindow;
  // Window c's cells m lie in [cK - 1, (c + 1)K - 1]: a box [mlo, mhi] of cells reaches it only when
  // floor((mlo + 1) / K) - 1 <= c <= floor((mhi + 1) / K).
  const auto range = [K](double lo, double hi, int n, int& a, int& b) {
    a = static_cast<int>(std::max(std::floor((std::floor(lo) + 1) / K) - 1, 0.0));
    b = static_cast<int>(std::min(std::floor((std::floor(hi) + 1) / K), static_cast<double>(n - 1)));
    return a <= b;
  };
  for (const int f : faces) {
    std::array<Vec2, 3> o;
    for (int k = 0; k < 3; ++k)
      o[static_cast<size_t>(k)] = source.layout->wedge_uv[static_cast<size_t>(source.atlas->face_wedge[static_cast<size_t>(f)][static_cast<size_t>(k)])];
    bool degenerate = false;
    output_det(o, degenerate);
    if (degenerate) continue;
    const double gxmin = std::min({o[0].x(), o[1].x(), o[2].x()}) - 0.5, gxmax = std::max({o[0].x(), o[1].x(), o[2].x()}) - 0.5;
    const double gymin = H - std::max({o[0].y(), o[1].y(), o[2].y()}) - 0.5, gymax = H - std::min({o[0].y(), o[1].y(), o[2].y()}) - 0.5;
    int c0, c1, r0, r1;
    if (!range(gxmin, gxmax, nx, c0, c1) || !range(gymin, gymax, ny, r0, r1)) continue;
    for (int r = r0; r <= r1; ++r)
      for (int c = c0; c <= c1; ++c) out[static_cast<size_t>(r) * static_cast<size_t>(nx) + static_cast<size_t>(c)].push_back(f);
  }
  return out;
}

/// The least-squares fit of every fitted texel of the page, window by window (kFitWindow), on up to
/// `threads` threads with the result of the raster order. A window's solve writes only its own
/// texels and reads them and a ring one texel wide around it, so window (i, j) (row i, column j)
/// must see (i-1, j+1), (i-1, j), (i-1, j-1) and (i, j-1) fitted and (i, j+1), (i+1, *) not yet
/// fitted. FitSchedule solves (i, j) after (i, j-1) and (i-1, min(j+1, nx-1)), which were solved
/// after the other two; (i, j+1) and (i+1, *) wait for (i, j) (directly or through (i+1, j-1) ->
/// (i, j)). A window's preparation (its right-hand side from the faces, about half its work) reads
/// no texel and runs whenever a thread is free. The texels are those of the raster order, byte for
/// byte, for any thread count. (Until 2026-12-04 windows ran in wavefronts t = 2 i + j, with a
/// barrier after each: one window on the first and last wavefronts.)
template <int C>
size_t fit_least_squares(const std::vector<int>& faces, const JobSource& source, const std::vector<const Image*>& inputs,
                         int iterations, Canvas& cv, int threads) {
  const int nx = (cv.w + kFitWindow - 1) / kFitWindow, ny = (cv.h + kFitWindow - 1) / kFitWindow;
  std::vector<std::vector<int>> per_window = window_faces(faces, source, cv.h, nx, ny);
  std::vector<std::unique_ptr<PreparedWindow>> prepared(per_window.size());
  std::vector<size_t> counts(per_window.size(), 0);
  const int workers = std::max(1, threads);
  FitSchedule schedule(nx, ny, static_cast<size_t>(nx) + 2 * static_cast<size_t>(workers));
  parallel_for(static_cast<size_t>(workers), workers, [&](size_t) {
    FitSchedule::Task t;
    try {
      while (schedule.next(t)) {
        const size_t w = t.window;
        if (t.solve) {
          counts[w] = solve_window<C>(*prepared[w], iterations, cv);
          prepared[w].reset();
        } else {
          const int x0 = static_cast<int>(w % static_cast<size_t>(nx)) * kFitWindow;
          const int y0 = static_cast<int>(w / static_cast<size_t>(nx)) * kFitWindow;
          prepared[w] = prepare_window<C>(per_window[w], source, inputs, cv, x0, y0, std::min(x0 + kFitWindow, cv.w),
                                          std::min(y0 + kFitWindow, cv.h));
          per_window[w] = std::vector<int>();
        }
        schedule.done(t);
      }
    } catch (...) {
      schedule.fail();
      throw;
    }
  });
  size_t fitted = 0;
  for (size_t c : counts) fitted += c;
  return fitted;
}

// ------------------------------------------------------------------------------------------------
// Gutter fill

/// Rows per block of the gutter fill's levels filled side by side (make_coarse, push_level).
constexpr int kFillRows = 64;
/// Blocks of kFillRows rows covering h rows.
size_t row_blocks(int h) { return static_cast<size_t>((h + kFillRows - 1) / kFillRows); }

/// One level of pull_push's pyramid: w * h texels, C floats each (`col`), and whether each has data.
struct PullLevel {
  int w = 0, h = 0;
  std::vector<float> col;  // w * h * C
  std::vector<uint8_t> has;
};

/// Pull: the level above a w x h one with C channels: each texel the average of the available
/// texels of its 2x2 block (has_at(x, y) says which; col_at(x, y, acc) adds one's colour to acc),
/// without data when none is available. Rows are independent: blocks of kFillRows rows on up to
/// `threads` threads.
template <class HasAt, class ColAt>
PullLevel make_coarse(int w, int h, int C, HasAt&& has_at, ColAt&& col_at, int threads) {
  PullLevel L;
  L.w = (w + 1) / 2;
  L.h = (h + 1) / 2;
  L.col.assign(static_cast<size_t>(L.w) * static_cast<size_t>(L.h) * static_cast<size_t>(C), 0.f);
  L.has.assign(static_cast<size_t>(L.w) * static_cast<size_t>(L.h), 0);
  parallel_for(row_blocks(L.h), threads, [&](size_t blk) {
    for (int y = static_cast<int>(blk) * kFillRows; y < std::min(L.h, (static_cast<int>(blk) + 1) * kFillRows); ++y)
      for (int x = 0; x < L.w; ++x) {
        float acc[4] = {0, 0, 0, 0};
        int n = 0;
        for (int dy = 0; dy < 2; ++dy)
          for (int dx = 0; dx < 2; ++dx) {
            const int fx = 2 * x + dx, fy = 2 * y + dy;
            if (fx >= w || fy >= h || !has_at(fx, fy)) continue;
            col_at(fx, fy, acc);
            ++n;
          }
        if (n == 0) continue;
        const size_t ci = static_cast<size_t>(y) * static_cast<size_t>(L.w) + static_cast<size_t>(x);
        L.has[ci] = 1;
        for (int c = 0; c < C; ++c) L.col[ci * static_cast<size_t>(C) + static_cast<size_t>(c)] = acc[c] / static_cast<float>(n);
      }
  });
  return L;
}

/// Push: every texel of a w x h level (C channels) for which needs(x, y) holds gets store(x, y, v)
/// with v the bilinear upsampling of the (fully filled) coarser level P at its position
/// ((x + 0.5) / 2 - 0.5, (y + 0.5) / 2 - 0.5). Per fine row the two coarse rows are blended once
/// into a scratch row (when the row needs anything), then each texel blends horizontally. Rows are
/// independent: blocks of kFillRows rows on up to `threads` threads.
template <class Needs, class Store>
void push_level(const PullLevel& P, int w, int h, int C, Needs&& needs, Store&& store, int threads) {
  parallel_for(row_blocks(h), threads, [&](size_t blk) {
    std::vector<float> blend(static_cast<size_t>(P.w) * static_cast<size_t>(C));
    for (int y = static_cast<int>(blk) * kFillRows; y < std::min(h, (static_cast<int>(blk) + 1) * kFillRows); ++y) {
      bool blended = false;
      const double gy = std::max((y + 0.5) / 2 - 0.5, 0.0);
      const int y0 = std::min(static_cast<int>(gy), P.h - 1), y1 = std::min(y0 + 1, P.h - 1);
      const float fy = static_cast<float>(gy - y0);
      for (int x = 0; x < w; ++x) {
        if (!needs(x, y)) continue;
        if (!blended) {
          const float* r0 = &P.col[static_cast<size_t>(y0) * static_cast<size_t>(P.w) * static_cast<size_t>(C)];
          const float* r1 = &P.col[static_cast<size_t>(y1) * static_cast<size_t>(P.w) * static_cast<size_t>(C)];
          for (size_t k = 0; k < blend.size(); ++k) blend[k] = r0[k] + fy * (r1[k] - r0[k]);
          blended = true;
        }
        const double gx = std::max((x + 0.5) / 2 - 0.5, 0.0);
        const int x0 = std::min(static_cast<int>(gx), P.w - 1), x1 = std::min(x0 + 1, P.w - 1);
        const float fx = static_cast<float>(gx - x0);
        const float* a = &blend[static_cast<size_t>(x0) * static_cast<size_t>(C)];
        const float* b = &blend[static_cast<size_t>(x1) * static_cast<size_t>(C)];
        float v[4];
        for (int c = 0; c < C; ++c) v[c] = a[c] + fx * (b[c] - a[c]);
        store(x, y, v);
      }
    }
  });
}

/// Pull-push: covered texels stay as they are; every other texel gets the colour of a pyramid of
/// averages of covered texels (pull: 2x2 averages of available texels; push: bilinear upsampling
/// of the coarser level into texels that had no data). No covered texel: the page is unchanged.
/// Each level's rows on up to `threads` threads (the same floats for any count).
void pull_push(Image& img, const std::vector<uint8_t>& state, int threads) {
  const int C = img.channels;
  std::vector<PullLevel> levels;
  // Level 1 from the page bytes.
  const int W = img.width, H = img.height;
  levels.push_back(make_coarse(
      W, H, C, [&](int x, int y) { return state[static_cast<size_t>(y) * static_cast<size_t>(W) + static_cast<size_t>(x)] != 0; },
      [&](int x, int y, float* acc) {
        const uint8_t* p = img.at(x, y);
        for (int c = 0; c < C; ++c) acc[c] += static_cast<float>(p[c]);
      },
      threads));
  while (levels.back().w > 1 || levels.back().h > 1) {
    const PullLevel& F = levels.back();
    PullLevel L = make_coarse(
        F.w, F.h, C, [&](int x, int y) { return F.has[static_cast<size_t>(y) * static_cast<size_t>(F.w) + static_cast<size_t>(x)] != 0; },
        [&](int x, int y, float* acc) {
          const float* p = &F.col[(static_cast<size_t>(y) * static_cast<size_t>(F.w) + static_cast<size_t>(x)) * static_cast<size_t>(C)];
          for (int c = 0; c < C; ++c) acc[c] += p[c];
        },
        threads);
    levels.push_back(std::move(L));
  }
  if (!levels.back().has[0]) return;  // nothing covered

  // Push, coarse to fine: the levels, then the page's texels that are not covered.
  for (size_t l = levels.size() - 1; l-- > 0;) {
    PullLevel& L = levels[l];
    const auto at = [&L](int x, int y) { return static_cast<size_t>(y) * static_cast<size_t>(L.w) + static_cast<size_t>(x); };
    push_level(levels[l + 1], L.w, L.h, C, [&](int x, int y) { return !L.has[at(x, y)]; },
               [&](int x, int y, const float* v) {
                 const size_t ci = at(x, y);
                 std::copy(v, v + C, &L.col[ci * static_cast<size_t>(C)]);
                 L.has[ci] = 1;
               },
               threads);
  }
  push_level(levels[0], W, H, C,
             [&](int x, int y) { return state[static_cast<size_t>(y) * static_cast<size_t>(W) + static_cast<size_t>(x)] == 0; },
             [&](int x, int y, const float* v) {
               uint8_t* p = img.at(x, y);
               for (int c = 0; c < C; ++c) p[c] = to_byte(v[c]);
             },
             threads);
}

/// Side of the blocks of fill_blocks: a JPEG block (8 x 8 texels from the page's top-left corner;
/// chroma is not subsampled in the default 4:4:4 pages, so colour has the same blocks).
constexpr int kFillBlock = 8;
/// Gauss-Seidel sweeps of the harmonic fill inside a partly written block (the slowest mode of an
/// 8 x 8 block decays by about 0.9 per sweep: 30 sweeps leave ~4% of the starting error).
constexpr int kHarmonicSweeps = 30;

/// One block of the page: texels [x0, x1) x [y0, y1), their values as floats (row-major in the
/// block, C per texel) and which ones a triangle wrote.
struct FillBlock {
  int x0 = 0, y0 = 0, w = 0, h = 0, C = 0;
  float v[kFillBlock * kFillBlock * 4] = {};
  bool known[kFillBlock * kFillBlock] = {};
  int num_known = 0;

  float* at(int x, int y) { return &v[(y * w + x) * C]; }
};

/// Reads block (bx, by) of the page: values and written flags.
FillBlock read_block(const Image& img, const std::vector<uint8_t>& state, int bx, int by) {
  FillBlock b;
  b.x0 = bx;
  b.y0 = by;
  b.w = std::min(kFillBlock, img.width - bx);
  b.h = std::min(kFillBlock, img.height - by);
  b.C = img.channels;
  for (int y = 0; y < b.h; ++y)
    for (int x = 0; x < b.w; ++x) {
      const bool k = state[static_cast<size_t>(by + y) * static_cast<size_t>(img.width) + static_cast<size_t>(bx + x)] != 0;
      b.known[y * b.w + x] = k;
      b.num_known += k;
      const uint8_t* p = img.at(bx + x, by + y);
      for (int c = 0; c < b.C; ++c) b.at(x, y)[c] = p[c];
    }
  return b;
}

/// The mean of the block's texels (known only, or all), per channel.
void block_mean(FillBlock& b, bool known_only, float mean[4]) {
  double acc[4] = {0, 0, 0, 0};
  int n = 0;
  for (int t = 0; t < b.w * b.h; ++t) {
    if (known_only && !b.known[t]) continue;
    for (int c = 0; c < b.C; ++c) acc[c] += b.v[t * b.C + c];
    ++n;
  }
  for (int c = 0; c < b.C; ++c) mean[c] = static_cast<float>(acc[c] / std::max(n, 1));
}

/// Harmonic fill of the block's unwritten texels: each becomes the mean of its 4 neighbours inside
/// the block (kHarmonicSweeps Gauss-Seidel sweeps from the known texels' mean); written texels stay.
/// The unwritten texels and their neighbours (left, right, up, down: the order of the sums) are
/// listed once, so a sweep is a pass over that list.
template <int C>
void harmonic_fill(FillBlock& b) {
  constexpr int kMax = kFillBlock * kFillBlock;
  int texel[kMax], nb[kMax][4], count[kMax];
  int U = 0;
  for (int y = 0; y < b.h; ++y)
    for (int x = 0; x < b.w; ++x) {
      const int t = y * b.w + x;
      if (b.known[t]) continue;
      int n = 0;
      if (x > 0) nb[U][n++] = t - 1;
      if (x + 1 < b.w) nb[U][n++] = t + 1;
      if (y > 0) nb[U][n++] = t - b.w;
      if (y + 1 < b.h) nb[U][n++] = t + b.w;
      texel[U] = t;
      count[U++] = n;
    }
  float mean[4];
  block_mean(b, true, mean);
  // note: the sweeps on all channels at once (Lanes: each lane's sums and quotients are the
  // channel-by-channel code's, in the same order).
  Lanes v[kMax];
  for (int t = 0; t < b.w * b.h; ++t) {
    v[t] = Lanes{};
    for (int c = 0; c < C; ++c) v[t][c] = b.v[t * C + c];
  }
  Lanes start = {};
  for (int c = 0; c < C; ++c) start[c] = mean[c];
  for (int i = 0; i < U; ++i) v[texel[i]] = start;
  for (int sweep = 0; sweep < kHarmonicSweeps; ++sweep)
    for (int i = 0; i < U; ++i) {
      Lanes acc = {};
      for (int k = 0; k < count[i]; ++k) acc += v[nb[i][k]];
      v[texel[i]] = acc / static_cast<float>(count[i]);
    }
  for (int i = 0; i < U; ++i)
    for (int c = 0; c < C; ++c) b.v[texel[i] * C + c] = v[texel[i]][c];
}

/// Fills block (bx, by) of the page (see fill_blocks).
void fill_block(Image& img, const std::vector<uint8_t>& state, int bx, int by) {
  // note: most blocks are fully written: told by their state alone, before the block's values are
  // read (and its 1.3 KB zeroed).
  const int w = std::min(kFillBlock, img.width - bx), h = std::min(kFillBlock, img.height - by);
  bool full = true;
  for (int y = 0; y < h && full; ++y) {
    const uint8_t* row = &state[static_cast<size_t>(by + y) * static_cast<size_t>(img.width) + static_cast<size_t>(bx)];
    for (int x = 0; x < w; ++x) full = full && row[x] != 0;
  }
  if (full) return;
  FillBlock b = read_block(img, state, bx, by);
  if (b.num_known == 0) {
    float mean[4];
    block_mean(b, false, mean);
    for (int t = 0; t < b.w * b.h; ++t) std::copy(mean, mean + b.C, &b.v[t * b.C]);
  } else {
    switch (b.C) {
      case 1: harmonic_fill<1>(b); break;
      case 2: harmonic_fill<2>(b); break;
      case 3: harmonic_fill<3>(b); break;
      default: harmonic_fill<4>(b); break;
    }
  }
  for (int y = 0; y < b.h; ++y)
    for (int x = 0; x < b.w; ++x)
      if (!b.known[y * b.w + x])
        for (int c = 0; c < b.C; ++c) img.at(bx + x, by + y)[c] = to_byte(b.at(x, y)[c]);
}

/// Fill for block-transform coders (ResampleOptions::fill_blocks), after the gutter fill: per 8 x 8
/// block, one no triangle wrote takes its mean (a flat block: one DC coefficient, where pull-push
/// left a gradient), and in one partly written the unwritten texels take the harmonic fill of the
/// written ones inside the block (the smoothest continuation: fewer high frequencies for the coder
/// to pay for than pull-push's, which blends colours from outside the block). Written texels are
/// never changed; every filled value is an average of values already on the page (MIP-mapping
/// still sees chart colours around charts). Rows of blocks run on up to `threads` threads: a block
/// reads and writes only its own texels, so the page does not depend on the thread count.
void fill_blocks(Image& img, const std::vector<uint8_t>& state, int threads) {
  const size_t rows = static_cast<size_t>((img.height + kFillBlock - 1) / kFillBlock);
  parallel_for(rows, threads, [&](size_t r) {
    const int by = static_cast<int>(r) * kFillBlock;
    for (int bx = 0; bx < img.width; bx += kFillBlock) fill_block(img, state, bx, by);
  });
}

/// Dilation: texels up to `width` steps (8-neighbourhood) from covered texels take the average of
/// their already coloured neighbours, ring by ring; the rest keep the background already there.
void dilate(Image& img, const std::vector<uint8_t>& state, int width) {
  const int W = img.width, H = img.height, C = img.channels;
  std::vector<uint8_t> filled(state.size());
  for (size_t i = 0; i < state.size(); ++i) filled[i] = state[i] != 0 ? 1 : 0;
  std::vector<int> ring, next;
  std::vector<uint8_t> queued(state.size(), 0);
  auto idx = [&](int x, int y) { return static_cast<size_t>(y) * static_cast<size_t>(W) + static_cast<size_t>(x); };
  auto push_neighbours_of = [&](int x, int y, std::vector<int>& out) {
    for (int dy = -1; dy <= 1; ++dy)
      for (int dx = -1; dx <= 1; ++dx) {
        const int nx = x + dx, ny = y + dy;
        if (nx < 0 || ny < 0 || nx >= W || ny >= H) continue;
        const size_t n = idx(nx, ny);
        if (filled[n] || queued[n]) continue;
        queued[n] = 1;
        out.push_back(static_cast<int>(n));
      }
  };
  if (width <= 0) return;
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x)
      if (filled[idx(x, y)]) push_neighbours_of(x, y, ring);
  std::vector<uint8_t> values;
  for (int step = 0; step < width && !ring.empty(); ++step) {
    values.assign(ring.size() * static_cast<size_t>(C), 0);
    for (size_t k = 0; k < ring.size(); ++k) {
      const int x = ring[k] % W, y = ring[k] / W;
      float acc[4] = {0, 0, 0, 0};
      int n = 0;
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) {
          const int nx = x + dx, ny = y + dy;
          if (nx < 0 || ny < 0 || nx >= W || ny >= H || !filled[idx(nx, ny)]) continue;
          const uint8_t* p = img.at(nx, ny);
          for (int c = 0; c < C; ++c) acc[c] += static_cast<float>(p[c]);
          ++n;
        }
      for (int c = 0; c < C; ++c) values[k * static_cast<size_t>(C) + static_cast<size_t>(c)] = to_byte(acc[c] / static_cast<float>(n));
    }
    for (size_t k = 0; k < ring.size(); ++k) {
      const size_t n = static_cast<size_t>(ring[k]);
      filled[n] = 1;
      std::memcpy(img.at(ring[k] % W, ring[k] / W), &values[k * static_cast<size_t>(C)], static_cast<size_t>(C));
    }
    next.clear();
    for (int n : ring) push_neighbours_of(n % W, n / W, next);
    ring.swap(next);
  }
}

// ------------------------------------------------------------------------------------------------
// Channel conversion: every input page is brought to the output channel count.

Image convert_channels(const Image& in, int C) {
  Image out;
  out.width = in.width;
  out.height = in.height;
  out.channels = C;
  const size_t n = static_cast<size_t>(in.width) * static_cast<size_t>(in.height);
  out.pixels.resize(n * static_cast<size_t>(C));
  const int ci = in.channels;
  const bool in_gray = ci <= 2, in_alpha = ci == 2 || ci == 4;
  for (size_t p = 0; p < n; ++p) {
    const uint8_t* s = &in.pixels[p * static_cast<size_t>(ci)];
    uint8_t* d = &out.pixels[p * static_cast<size_t>(C)];
    const uint8_t alpha = in_alpha ? s[ci - 1] : 255;
    if (C == 1) d[0] = s[0];
    else if (C == 2) { d[0] = s[0]; d[1] = alpha; }
    else {
      for (int c = 0; c < 3; ++c) d[c] = in_gray ? s[0] : s[c];
      if (C == 4) d[3] = alpha;
    }
  }
  return out;
}

// ------------------------------------------------------------------------------------------------
// Progress shared by the worker threads; only the calling thread talks to the callback.

struct Progress {
  const ProgressFn* fn = nullptr;
  std::thread::id owner;
  double total = 1;
  std::atomic<size_t> done{0};
  std::atomic<bool> cancelled{false};
  double last = -1;

  void report(double fraction) {
    if (!*fn || cancelled || fraction <= last) return;
    if (fraction < 1 && fraction - last < 0.001) return;
    last = fraction;
    if (!(*fn)("texture.resample", std::min(fraction, 1.0))) cancelled = true;
  }
  void tick(size_t units) {
    const size_t d = done.fetch_add(units) + units;
    if (std::this_thread::get_id() == owner) report(static_cast<double>(d) / total);
  }
};

constexpr size_t kFacesPerTick = 2048;
constexpr size_t kFillTexelsPerUnit = 64;

/// An output page's faces, in face order.
struct PageTask {
  std::vector<int> faces;
};

/// Rows of a band of a page drawn side by side (render_page_jobs): faces crossing a band border are
/// set up once per band they reach (a 30 MP page of 1M faces: about 5% more set-ups at 128 rows).
constexpr int kRenderBand = 128;

/// Draws `faces` (in face order) on the rows of `band` (counting the faces it counts), ticking prog.
template <int C>
void render_band(const std::vector<int>& faces, const JobSource& source, const std::vector<const Image*>& inputs,
                 Filter filter, Canvas& cv, PageStats& st, Progress& prog, const std::vector<int>& home, int band,
                 const RowRange& rows) {
  size_t since = 0;
  for (size_t n = 0; n < faces.size(); ++n) {
    const FaceJob job = source.job(faces[n]);
    const Image& in = *inputs[static_cast<size_t>(job.in_page)];
    Sampler<C> s;
    s.px = in.pixels.data();
    s.w = in.width;
    s.h = in.height;
    s.repeat = job.repeat;
    RowRange r = rows;
    r.count = home.empty() || home[n] == band;
    render_face<C>(job, s, filter, cv, st, r);
    if (r.count && ++since == kFacesPerTick) {
      prog.tick(since);
      since = 0;
      if (prog.cancelled) return;
    }
  }
  prog.tick(since);
}

/// The faces of each band of kRenderBand rows that a face's texel window reaches (in face order),
/// and beside each the band where it is counted (its window's first row, clipped to the canvas: a
/// face reaching no row is listed there alone).
void band_faces(const std::vector<int>& faces, const JobSource& source, const Canvas& cv,
                std::vector<std::vector<int>>& band, std::vector<std::vector<int>>& home) {
  const int nb = (cv.h + kRenderBand - 1) / kRenderBand;
  band.assign(static_cast<size_t>(nb), {});
  home.assign(static_cast<size_t>(nb), {});
  for (const int f : faces) {
    std::array<Vec2, 3> o;
    for (int k = 0; k < 3; ++k)
      o[static_cast<size_t>(k)] = source.layout->wedge_uv[static_cast<size_t>(source.atlas->face_wedge[static_cast<size_t>(f)][static_cast<size_t>(k)])];
    const TexelWindow win = texel_window(o, cv.w, cv.h);
    const int j0 = std::max(win.jlo, 0), j1 = std::min(win.jhi, cv.h - 1);
    const int h = std::clamp(win.jlo, 0, cv.h - 1) / kRenderBand;
    const int b0 = j0 <= j1 ? j0 / kRenderBand : h, b1 = j0 <= j1 ? j1 / kRenderBand : h;
    for (int b = b0; b <= b1; ++b) {
      band[static_cast<size_t>(b)].push_back(f);
      home[static_cast<size_t>(b)].push_back(h);
    }
  }
}

/// Draws every face of the page in face order. With threads > 1 the page's rows are split into bands
/// of kRenderBand rows drawn side by side, each drawing the faces that reach it in face order on its
/// own rows only: every texel sees the same faces in the same order as when drawn whole.
template <int C>
void render_page_jobs(const std::vector<int>& faces, const JobSource& source, const std::vector<const Image*>& inputs,
                      Filter filter, Canvas& cv, PageStats& st, Progress& prog, int threads) {
  if (threads <= 1 || cv.h <= kRenderBand) {
    render_band<C>(faces, source, inputs, filter, cv, st, prog, {}, 0, RowRange{0, cv.h - 1, true});
    return;
  }
  std::vector<std::vector<int>> band, home;
  band_faces(faces, source, cv, band, home);
  std::vector<PageStats> stats(band.size());
  parallel_for(band.size(), threads, [&](size_t b) {
    const int lo = static_cast<int>(b) * kRenderBand;
    render_band<C>(band[b], source, inputs, filter, cv, stats[b], prog, home[b], static_cast<int>(b),
                   RowRange{lo, std::min(lo + kRenderBand, cv.h) - 1, true});
    band[b] = std::vector<int>();
    home[b] = std::vector<int>();
  });
  for (const PageStats& s : stats) {
    st.faces_copied += s.faces_copied;
    st.faces_resampled += s.faces_resampled;
  }
}

void render_page(const PageTask& task, const JobSource& source, const std::vector<const Image*>& inputs,
                 const ResampleOptions& opt, Image& out, ResampleStats& st, Progress& prog, int threads) {
  const int C = out.channels;
  Canvas cv;
  cv.img = &out;
  cv.w = out.width;
  cv.h = out.height;
  const size_t n = static_cast<size_t>(cv.w) * static_cast<size_t>(cv.h);
  cv.state.assign(n, kEmpty);
  cv.dist.reset(new float[n]);
  PageStats ps;
  switch (C) {
    case 1: render_page_jobs<1>(task.faces, source, inputs, opt.filter, cv, ps, prog, threads); break;
    case 2: render_page_jobs<2>(task.faces, source, inputs, opt.filter, cv, ps, prog, threads); break;
    case 3: render_page_jobs<3>(task.faces, source, inputs, opt.filter, cv, ps, prog, threads); break;
    default: render_page_jobs<4>(task.faces, source, inputs, opt.filter, cv, ps, prog, threads); break;
  }
  if (prog.cancelled) return;
  // note: the distances serve only the rendering (4 bytes per texel: 120 MB on a 30 MP page).
  cv.dist.reset();
  if (opt.fit == TexelFit::LeastSquares) {
    switch (C) {
      case 1: st.texels_fitted = fit_least_squares<1>(task.faces, source, inputs, opt.fit_iterations, cv, threads); break;
      case 2: st.texels_fitted = fit_least_squares<2>(task.faces, source, inputs, opt.fit_iterations, cv, threads); break;
      case 3: st.texels_fitted = fit_least_squares<3>(task.faces, source, inputs, opt.fit_iterations, cv, threads); break;
      default: st.texels_fitted = fit_least_squares<4>(task.faces, source, inputs, opt.fit_iterations, cv, threads); break;
    }
  }
  st.faces_copied = ps.faces_copied;
  st.faces_resampled = ps.faces_resampled;
  for (uint8_t s : cv.state) {
    if (s & kCoverMask) st.texels_written++;
    if (s & kCopied) st.texels_copied++;
  }
  switch (opt.fill) {
    case GutterFill::None: break;
    case GutterFill::Dilate: dilate(out, cv.state, opt.dilate_width); break;
    case GutterFill::PullPush: pull_push(out, cv.state, threads); break;
  }
  if (opt.fill_blocks && opt.fill == GutterFill::PullPush) fill_blocks(out, cv.state, threads);
  prog.tick(n / kFillTexelsPerUnit);
}

/// Finite and within 1e9 texels (keeps every product of coordinates far from overflow).
bool sane(const Vec2& v) { return std::abs(v.x()) < 1e9 && std::abs(v.y()) < 1e9; }

// resample_atlas's steps: validate, convert the inputs, list each output page's faces, prepare
// blank pages, render them in parallel.

/// Throws StageError ("texture.resample: ...") unless the arguments agree: one image per mesh page, one atlas entry per
/// face, fit_iterations >= 1 and dilate_width >= 0 when used, output pages of 1..kMaxPageSide.
void check_arguments(const TexturedMesh& mesh, const std::vector<Image>& input_pages, const Atlas& atlas,
                     const Layout& layout, const ResampleOptions& options) {
  if (input_pages.size() != mesh.pages.size()) {
    std::ostringstream s;
    s << input_pages.size() << " input page images for " << mesh.pages.size() << " mesh pages";
    fail(s.str());
  }
  if (atlas.face_chart.size() != mesh.faces.size() || atlas.face_wedge.size() != mesh.faces.size())
    fail("atlas has " + std::to_string(atlas.face_chart.size()) + " faces, mesh has " + std::to_string(mesh.faces.size()));
  if (options.fit == TexelFit::LeastSquares && options.fit_iterations < 1)
    fail("fit_iterations = " + std::to_string(options.fit_iterations) + " is below 1");
  if (options.fill == GutterFill::Dilate && options.dilate_width < 0)
    fail("dilate_width = " + std::to_string(options.dilate_width) + " is negative");
  for (size_t p = 0; p < layout.pages.size(); ++p) {
    const auto& ps = layout.pages[p];
    if (ps.width <= 0 || ps.height <= 0 || ps.width > kMaxPageSide || ps.height > kMaxPageSide)
      fail("output page " + std::to_string(p) + " has size " + std::to_string(ps.width) + "x" +
           std::to_string(ps.height) + " (expected 1.." + std::to_string(kMaxPageSide) + ")");
  }
}

/// Throws StageError naming the face (and its OBJ line) unless every textured face has a
/// chart, an input page, an output page, wedges and texcoords in range and sane UVs on both sides.
/// Returns which input pages some face reads.
std::vector<char> check_faces(const TexturedMesh& mesh, const Atlas& atlas, const Layout& layout) {
  std::vector<char> page_used(mesh.pages.size(), 0);
  for (size_t f = 0; f < mesh.faces.size(); ++f) {
    const Face& F = mesh.faces[f];
    const int chart = atlas.face_chart[f];
    if (F.page == kNoPage && chart < 0) continue;
    // note: the face's name is built only for a message (once per face, it cost an allocation each).
    const auto where = [&] { return "face " + std::to_string(f) + " (OBJ line " + std::to_string(F.source_line) + ")"; };
    if (F.page == kNoPage || chart < 0) fail(where() + ": textured in only one of mesh and atlas");
    if (F.page < 0 || static_cast<size_t>(F.page) >= mesh.pages.size()) fail(where() + ": page " + std::to_string(F.page) + " out of range");
    if (static_cast<size_t>(chart) >= layout.chart_page.size())
      fail(where() + ": chart " + std::to_string(chart) + " has no output page in the layout");
    const int op = layout.chart_page[static_cast<size_t>(chart)];
    if (op < 0 || static_cast<size_t>(op) >= layout.pages.size())
      fail("chart " + std::to_string(chart) + ": output page " + std::to_string(op) + " out of range");
    for (int k = 0; k < 3; ++k) {
      const int w = atlas.face_wedge[f][static_cast<size_t>(k)];
      if (w < 0 || static_cast<size_t>(w) >= layout.wedge_uv.size()) fail(where() + ": wedge " + std::to_string(w) + " out of range");
      if (!sane(layout.wedge_uv[static_cast<size_t>(w)])) fail(where() + ": output UV is not finite or beyond 1e9 texels");
      const int vt = F.vt[static_cast<size_t>(k)];
      if (vt < 0 || static_cast<size_t>(vt) >= mesh.texcoords.size()) fail(where() + ": texcoord index out of range");
      if (!sane(mesh.corner_texel(f, k))) fail(where() + ": input UV is not finite or beyond 1e9 texels");
    }
    page_used[static_cast<size_t>(F.page)] = 1;
  }
  return page_used;
}

/// Throws StageError unless every used (or non-empty) input page is a consistent image of 1..4
/// channels of its mesh page's size. Returns the output channel count: the largest input's (3
/// when no page is used).
int check_input_pages(const TexturedMesh& mesh, const std::vector<Image>& input_pages, const std::vector<char>& page_used) {
  int channels = 0;
  for (size_t p = 0; p < input_pages.size(); ++p) {
    const Image& im = input_pages[p];
    if (!page_used[p] && im.empty()) continue;
    const std::string where = "input page " + std::to_string(p) + " (" + mesh.pages[p].image_path + ")";
    if (im.channels < 1 || im.channels > 4) fail(where + ": " + std::to_string(im.channels) + " channels (expected 1..4)");
    if (im.width <= 0 || im.height <= 0 ||
        im.pixels.size() != static_cast<size_t>(im.width) * static_cast<size_t>(im.height) * static_cast<size_t>(im.channels))
      fail(where + ": empty or inconsistent image");
    if (page_used[p] && (im.width != mesh.pages[p].width || im.height != mesh.pages[p].height))
      fail(where + ": image is " + std::to_string(im.width) + "x" + std::to_string(im.height) + ", mesh page says " +
           std::to_string(mesh.pages[p].width) + "x" + std::to_string(mesh.pages[p].height));
    channels = std::max(channels, im.channels);
  }
  if (channels == 0) channels = 3;
  return channels;
}

/// The used input pages at `channels` channels: a pointer to the caller's image when it has them
/// already, else to its conversion stored in `converted` (which must outlive the pointers).
std::vector<const Image*> inputs_at_channels(const std::vector<Image>& input_pages, const std::vector<char>& page_used,
                                             int channels, std::vector<Image>& converted) {
  converted.assign(input_pages.size(), Image());
  std::vector<const Image*> inputs(input_pages.size(), nullptr);
  for (size_t p = 0; p < input_pages.size(); ++p) {
    if (!page_used[p]) continue;
    if (input_pages[p].channels == channels) {
      inputs[p] = &input_pages[p];
    } else {
      converted[p] = convert_channels(input_pages[p], channels);
      inputs[p] = &converted[p];
    }
  }
  return inputs;
}

/// The faces of each output page, in face order (their jobs come from a JobSource). Adds the number
/// of faces to num_jobs.
std::vector<PageTask> page_tasks(const TexturedMesh& mesh, const Atlas& atlas, const Layout& layout, size_t& num_jobs) {
  std::vector<PageTask> tasks(layout.pages.size());
  for (size_t f = 0; f < mesh.faces.size(); ++f) {
    const int chart = atlas.face_chart[f];
    if (chart < 0) continue;
    tasks[static_cast<size_t>(layout.chart_page[static_cast<size_t>(chart)])].faces.push_back(static_cast<int>(f));
    ++num_jobs;
  }
  return tasks;
}

/// The output pages of `layout` with `channels` channels, every texel the background (grey-alpha
/// takes its first and fourth bytes). Adds the pages' gutter-fill progress units to fill_units.
std::vector<Image> blank_pages(const Layout& layout, int channels, const uint8_t* background, size_t& fill_units) {
  std::vector<Image> out(layout.pages.size());
  for (size_t p = 0; p < out.size(); ++p) {
    Image& im = out[p];
    im.width = layout.pages[p].width;
    im.height = layout.pages[p].height;
    im.channels = channels;
    const size_t n = static_cast<size_t>(im.width) * static_cast<size_t>(im.height);
    im.pixels.resize(n * static_cast<size_t>(channels));
    uint8_t bg[4];
    const uint8_t* b = background;
    if (channels == 1) bg[0] = b[0];
    else if (channels == 2) { bg[0] = b[0]; bg[1] = b[3]; }
    else std::memcpy(bg, b, static_cast<size_t>(channels));
    // One row texel by texel, then every other row copied from it.
    const size_t row = static_cast<size_t>(im.width) * static_cast<size_t>(channels);
    for (size_t t = 0; t < static_cast<size_t>(im.width); ++t)
      std::memcpy(&im.pixels[t * static_cast<size_t>(channels)], bg, static_cast<size_t>(channels));
    for (int y = 1; y < im.height; ++y) std::memcpy(&im.pixels[static_cast<size_t>(y) * row], im.pixels.data(), row);
    fill_units += n / kFillTexelsPerUnit;
  }
  return out;
}

/// Renders every page of `out` (page p from tasks[p]) on the framework's threads, one page per
/// thread, biggest first; the calling thread also reports progress. Rethrows the first error;
/// stops early (prog.cancelled) when the progress callback cancels. The texels depend on neither
/// the thread count nor the order.
void render_pages(const std::vector<PageTask>& tasks, const JobSource& source, const std::vector<const Image*>& inputs,
                  const ResampleOptions& options, std::vector<Image>& out, std::vector<ResampleStats>& page_stats,
                  Progress& prog) {
  // note: the biggest pages first (by texels, then faces), so the last page to finish is a small
  // one; each page is rendered by one thread and depends on nothing else, so the order does not
  // change any texel.
  std::vector<size_t> order(out.size());
  for (size_t p = 0; p < order.size(); ++p) order[p] = p;
  std::stable_sort(order.begin(), order.end(), [&](size_t a, size_t b) {
    const size_t ta = out[a].pixels.size() + 64 * tasks[a].faces.size(), tb = out[b].pixels.size() + 64 * tasks[b].faces.size();
    return ta > tb;
  });
  const size_t nthreads = std::min<size_t>(static_cast<size_t>(thread_count()), out.size());
  // note: threads left over when there are fewer pages than threads work inside a page (the
  // least-squares fit's windows); the texels do not depend on either count.
  const int inner_threads = std::max(1, thread_count() / static_cast<int>(std::max<size_t>(nthreads, 1)));
  std::atomic<size_t> next{0};
  std::mutex mtx;
  std::condition_variable cv;
  std::exception_ptr error;
  size_t running = 0;
  auto worker = [&]() {
    try {
      for (;;) {
        const size_t k = next.fetch_add(1);
        if (k >= out.size() || prog.cancelled) break;
        const size_t p = order[k];
        render_page(tasks[p], source, inputs, options, out[p], page_stats[p], prog, inner_threads);
      }
    } catch (...) {
      std::lock_guard<std::mutex> lock(mtx);
      if (!error) error = std::current_exception();
      prog.cancelled = true;
    }
  };
  std::vector<std::thread> threads;
  for (size_t t = 1; t < nthreads; ++t) {
    {
      std::lock_guard<std::mutex> lock(mtx);
      ++running;
    }
    threads.emplace_back([&]() {
      worker();
      std::lock_guard<std::mutex> lock(mtx);
      --running;
      cv.notify_all();
    });
  }
  worker();
  {
    std::unique_lock<std::mutex> lock(mtx);
    while (running > 0) {
      cv.wait_for(lock, std::chrono::milliseconds(20));
      lock.unlock();
      prog.report(static_cast<double>(prog.done.load()) / prog.total);
      lock.lock();
    }
  }
  for (auto& t : threads) t.join();
  if (error) std::rethrow_exception(error);
}

}  // namespace

std::vector<Image> resample_atlas(const TexturedMesh& mesh, const std::vector<Image>& input_pages,
                                  const Atlas& atlas, const Layout& layout, const ResampleOptions& options,
                                  ResampleStats* stats, const ProgressFn& progress) {
  check_arguments(mesh, input_pages, atlas, layout, options);
  const std::vector<char> page_used = check_faces(mesh, atlas, layout);
  const int channels = check_input_pages(mesh, input_pages, page_used);
  std::vector<Image> converted;
  const std::vector<const Image*> inputs = inputs_at_channels(input_pages, page_used, channels, converted);
  size_t num_jobs = 0, fill_units = 0;
  const std::vector<PageTask> tasks = page_tasks(mesh, atlas, layout, num_jobs);
  std::vector<Image> out = blank_pages(layout, channels, options.background, fill_units);

  // Render, pages in parallel; the calling thread reports progress.
  Progress prog;
  prog.fn = &progress;
  prog.owner = std::this_thread::get_id();
  prog.total = static_cast<double>(std::max<size_t>(num_jobs + fill_units, 1));
  prog.report(0);
  if (prog.cancelled) throw Cancelled();
  std::vector<ResampleStats> page_stats(out.size());
  const JobSource source{&mesh, &atlas, &layout};
  render_pages(tasks, source, inputs, options, out, page_stats, prog);
  if (prog.cancelled) throw Cancelled();
  prog.report(1.0);
  if (prog.cancelled) throw Cancelled();

  if (stats) {
    *stats = ResampleStats{};
    for (const auto& s : page_stats) {
      stats->texels_written += s.texels_written;
      stats->texels_copied += s.texels_copied;
      stats->faces_copied += s.faces_copied;
      stats->faces_resampled += s.faces_resampled;
      stats->texels_fitted += s.texels_fitted;
    }
  }
  return out;
}

}  // namespace texdefrag
