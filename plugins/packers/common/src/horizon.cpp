// Column-profile horizon packing (Lévy et al. 2002, section 5; the M-method's packer): profiles,
// horizon, and the drop search. See horizon.h.
#include "texdefrag/packers/horizon.h"

#include <algorithm>

namespace texdefrag::packing {

Profile make_profile(const PackChart& c, int q, const CommonSettings& s) {
  const Mask m = dilate(c.raster(q), s.gutter / 2, s.gutter - s.gutter / 2);
  Profile p;
  p.w = m.width;
  p.h = m.height;
  p.bottom.assign(static_cast<size_t>(m.width), INT_MAX);
  p.top.assign(static_cast<size_t>(m.width), 0);
  for (int x = 0; x < m.width; ++x)
    for (int y = 0; y < m.height; ++y)
      if (m.at(x, y)) {
        p.bottom[static_cast<size_t>(x)] = std::min(p.bottom[static_cast<size_t>(x)], y);
        p.top[static_cast<size_t>(x)] = y + 1;
      }
  return p;
}



/// Best drop of profile p on horizon `hz` (height limit Hmax).
/// Cost = area wasted between the horizon and the chart's bottom profile + page area added above
/// the current used height (rows the chart adds times the page width). Ties: lower top, then left.
/// note: for profiles without empty columns, the window maximum of H bounds the drop height from
/// below (y >= max H - max bottom) and the cost grows with y, so offsets whose bound cannot beat
/// the best are skipped without scanning the profile; the offset with the lowest bound is
/// evaluated first to get a good best early.
Drop best_drop(Horizon& hz, int Hmax, const Profile& p) {
  Drop best;
  const std::vector<int>& H = hz.H;
  const int W = static_cast<int>(H.size());
  if (p.w > W || p.h > Hmax) return best;
  int bmax = 0, filled = 0;
  long long bsum = 0;
  for (int c = 0; c < p.w; ++c) {
    const int b = p.bottom[static_cast<size_t>(c)];
    if (b == INT_MAX) continue;
    bmax = std::max(bmax, b);
    bsum += b;
    ++filled;
  }
  if (filled == 0) return best;
  const bool solid = filled == p.w;
  auto exact_y = [&](int x) {
    int y = 0;
    for (int c = 0; c < p.w; ++c)
      if (p.bottom[static_cast<size_t>(c)] != INT_MAX)
        y = std::max(y, H[static_cast<size_t>(x + c)] - p.bottom[static_cast<size_t>(c)]);
    return y;
  };
  auto cost_of = [&](int x, int y) {
    long long waste;
    if (solid) {
      waste = static_cast<long long>(filled) * y + bsum -
              (hz.prefix[static_cast<size_t>(x + p.w)] - hz.prefix[static_cast<size_t>(x)]);
    } else {
      waste = 0;
      for (int c = 0; c < p.w; ++c)
        if (p.bottom[static_cast<size_t>(c)] != INT_MAX)
          waste += y + p.bottom[static_cast<size_t>(c)] - H[static_cast<size_t>(x + c)];
    }
    return waste + static_cast<long long>(std::max(0, y + p.h - hz.used)) * W;
  };
  auto consider = [&](int x) {
    const int y = exact_y(x);
    if (y + p.h > Hmax) return;
    const long long cost = cost_of(x, y);
    const int top = y + p.h;
    if (!best.found || cost < best.cost || (cost == best.cost && (top < best.top || (top == best.top && x < best.x))))
      best = Drop{true, x, y, cost, top};
  };
  const int n = W - p.w + 1;
  if (!solid) {
    for (int x = 0; x < n; ++x) consider(x);
    return best;
  }
  // Window maximum of H over [x, x + w) (van Herk / Gil-Werman: per-block prefix and suffix
  // maxima), then the lower bounds of the drop height and of the cost at every offset. The passes
  // are branch-free loops over the columns (vectorised by the compiler).
  const int w = p.w;
  std::vector<int>& g = hz.dq;   // prefix maxima within blocks of w columns
  std::vector<int>& sf = hz.lb;  // suffix maxima within blocks, then the height bound per offset
  const int* Hp = H.data();
  for (int b0 = 0; b0 < W; b0 += w) {
    const int b1 = std::min(W, b0 + w);
    int run = Hp[b0];
    for (int i = b0; i < b1; ++i) g[static_cast<size_t>(i)] = run = std::max(run, Hp[i]);
    run = Hp[b1 - 1];
    for (int i = b1 - 1; i >= b0; --i) sf[static_cast<size_t>(i)] = run = std::max(run, Hp[i]);
  }
  // A few profile columns sharpen the bound: y >= H[x + c] - bottom[c] for any column c.
  int deep = 0;
  for (int c = 0; c < w; ++c)
    if (p.bottom[static_cast<size_t>(c)] < p.bottom[static_cast<size_t>(deep)]) deep = c;
  const int c1 = w - 1, c2 = w / 2;
  const int b0v = p.bottom[0], b1v = p.bottom[static_cast<size_t>(c1)], b2v = p.bottom[static_cast<size_t>(c2)],
            b3v = p.bottom[static_cast<size_t>(deep)];
  std::vector<long long>& cl = hz.cost_lb;
  cl.resize(static_cast<size_t>(n));
  const long long* pre = hz.prefix.data();
  const int* gp = g.data();
  int* lbp = sf.data();
  long long* clp = cl.data();
  const long long used = hz.used, ph = p.h, Wl = W, fl = filled;
  for (int x = 0; x < n; ++x) {
    int lb = std::max(lbp[x], gp[x + w - 1]) - bmax;
    lb = std::max(lb, Hp[x] - b0v);
    lb = std::max(lb, Hp[x + c1] - b1v);
    lb = std::max(lb, Hp[x + c2] - b2v);
    lb = std::max(lb, Hp[x + deep] - b3v);
    lb = std::max(lb, 0);
    lbp[x] = lb;
    const long long add = std::max(0LL, lb + ph - used);
    clp[x] = fl * lb + bsum - (pre[x + w] - pre[x]) + add * Wl;
  }
  int first = -1;
  for (int x = 0; x < n; ++x)
    if (lbp[x] + p.h <= Hmax && (first < 0 || clp[x] < clp[static_cast<size_t>(first)])) first = x;
  if (first < 0) return best;
  consider(first);
  for (int x = 0; x < n; ++x) {
    // skip offsets that cannot win even at the lowest possible height
    if (clp[x] > best.cost || x == first) continue;
    const int tlb = lbp[x] + p.h;
    if (tlb > Hmax || (clp[x] == best.cost && (tlb > best.top || (tlb == best.top && x > best.x)))) continue;
    consider(x);
  }
  return best;
}

std::vector<Profile> make_profiles(const PackChart& c, const CommonSettings& s) {
  std::vector<Profile> profs;
  for (int q = 0; q < (s.allow_rotation ? 4 : 1); ++q) {
    profs.push_back(make_profile(c, q, s));
    // A turn giving the same outline as an earlier one (boxes: 180 degrees) is not tried again.
    for (int e = 0; e < q; ++e) {
      const Profile& a = profs[static_cast<size_t>(e)];
      if (!a.duplicate && a.bottom == profs.back().bottom && a.top == profs.back().top && a.h == profs.back().h) {
        profs.back().duplicate = true;
        break;
      }
    }
  }
  return profs;
}

Horizon::Horizon(int width)
    : H(static_cast<size_t>(width), 0), prefix(static_cast<size_t>(width) + 1, 0), lb(static_cast<size_t>(width), 0),
      dq(static_cast<size_t>(width), 0) {}

Horizon::Horizon(std::vector<int> heights) : Horizon(static_cast<int>(heights.size())) {
  H = std::move(heights);
  for (int h : H) used = std::max(used, h);
  update(0);
}

void Horizon::update(int from) {
  for (size_t x = static_cast<size_t>(from); x < H.size(); ++x) prefix[x + 1] = prefix[x] + H[x];
}

void Horizon::place(const Profile& p, const Drop& d) {
  for (int c = 0; c < p.w; ++c)
    if (p.top[static_cast<size_t>(c)] > 0) H[static_cast<size_t>(d.x + c)] = d.y + p.top[static_cast<size_t>(c)];
  update(d.x);
  used = std::max(used, d.top);
}

}  // namespace texdefrag::packing
