// Helpers shared by the real-model resampling tests: load a model with its pages, lay charts out
// shifted on their input pages, compare texels inside triangles with the input.
#pragma once

#include "texdefrag/core/charts.h"
#include "texdefrag/core/topology.h"
#include "texdefrag/io/image.h"
#include "texdefrag/io/obj.h"
#include "texdefrag/texture/resample.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

namespace texdefrag::resample_test {

struct Loaded {
  TexturedMesh mesh;
  ChartSet charts;
  std::vector<Image> pages;
};

inline Loaded load(const std::string& path) {
  Loaded l;
  l.mesh = read_obj(path);
  const Topology topo = build_topology(l.mesh);
  l.charts = build_charts(l.mesh, topo);
  l.pages.resize(l.mesh.pages.size());
  std::vector<char> used(l.mesh.pages.size(), 0);
  for (const Face& f : l.mesh.faces)
    if (f.page != kNoPage) used[static_cast<size_t>(f.page)] = 1;
  for (size_t p = 0; p < l.pages.size(); ++p)
    if (used[p]) l.pages[p] = read_image(l.mesh.pages[p].image_path);
  return l;
}

/// Every chart stays on its input page, moved by `shift` texels; pages grow by `grow` texels.
inline Layout shifted_layout(const Loaded& l, const Vec2& shift, int grow) {
  Layout lay;
  for (const Page& p : l.mesh.pages) lay.pages.push_back({p.width + grow, p.height + grow});
  lay.chart_page = l.charts.atlas.chart_page;
  lay.wedge_uv = l.charts.atlas.wedge_uv;
  for (Vec2& uv : lay.wedge_uv) uv += shift;
  return lay;
}

struct Compared {
  size_t checked = 0, differ = 0;
  double sum_abs = 0;  ///< sum over checked texels and channels of |output - input|
};

/// Compares output texels whose centre is well inside a non-degenerate triangle with the input
/// texel at the same place minus the whole-texel part (sx, sy) of the layout's shift.
inline Compared compare_inside(const Loaded& l, const Layout& lay, const std::vector<Image>& out, int sx, int sy) {
  Compared r;
  const Atlas& atlas = l.charts.atlas;
  for (size_t f = 0; f < l.mesh.faces.size(); ++f) {
    if (atlas.face_chart[f] < 0) continue;
    const int page = l.mesh.faces[f].page;
    const Image& in = l.pages[static_cast<size_t>(page)];
    const Image& o = out[static_cast<size_t>(lay.chart_page[static_cast<size_t>(atlas.face_chart[f])])];
    Vec2 c[3];
    for (int k = 0; k < 3; ++k) c[k] = lay.wedge_uv[static_cast<size_t>(atlas.face_wedge[f][static_cast<size_t>(k)])];
    const double det = (c[1] - c[0]).x() * (c[2] - c[0]).y() - (c[1] - c[0]).y() * (c[2] - c[0]).x();
    if (std::abs(det) < 1e-3) continue;
    const double xmin = std::min({c[0].x(), c[1].x(), c[2].x()}), xmax = std::max({c[0].x(), c[1].x(), c[2].x()});
    const double ymin = std::min({c[0].y(), c[1].y(), c[2].y()}), ymax = std::max({c[0].y(), c[1].y(), c[2].y()});
    for (int j = std::max(0, static_cast<int>(o.height - ymax) - 1); j < std::min(o.height, static_cast<int>(o.height - ymin) + 1); ++j)
      for (int i = std::max(0, static_cast<int>(xmin) - 1); i < std::min(o.width, static_cast<int>(xmax) + 1); ++i) {
        const Vec2 p(i + 0.5, o.height - j - 0.5);
        bool inside = true;
        for (int k = 0; k < 3 && inside; ++k) {
          const Vec2 a = c[k], b = c[(k + 1) % 3];
          const double e = ((b - a).x() * (p - a).y() - (b - a).y() * (p - a).x()) / (b - a).norm();
          inside = (det > 0 ? e : -e) > 1e-6;
        }
        if (!inside) continue;
        // input texel: same texel-space position minus the shift
        const int ii = i - sx, jj = j - (o.height - in.height) + sy;
        if (ii < 0 || jj < 0 || ii >= in.width || jj >= in.height) continue;
        ++r.checked;
        const uint8_t* a = o.at(i, j);
        const uint8_t* b = in.at(ii, jj);
        bool same = true;
        for (int ch = 0; ch < in.channels; ++ch) {
          same = same && a[ch] == b[ch];
          r.sum_abs += std::abs(a[ch] - b[ch]);
        }
        r.differ += !same;
      }
  }
  return r;
}

/// Identity and a whole-texel shift onto larger pages: every face is copied (zero-area ones too:
/// their corners move by whole texels as well), every texel written is a copy, and every texel
/// inside a triangle equals its input texel.
inline void expect_whole_texel_layouts_bit_exact(const std::string& path) {
  SCOPED_TRACE(path);
  const Loaded l = load(path);
  size_t textured = 0;
  for (size_t f = 0; f < l.mesh.faces.size(); ++f) textured += l.charts.atlas.face_chart[f] >= 0;
  for (const auto& [shift, grow] : {std::pair<Vec2, int>{Vec2(0, 0), 0}, {Vec2(7, 3), 16}}) {
    const Layout lay = shifted_layout(l, shift, grow);
    ResampleStats st;
    const auto out = resample_atlas(l.mesh, l.pages, l.charts.atlas, lay, ResampleOptions{}, &st);
    ASSERT_EQ(out.size(), l.mesh.pages.size());
    EXPECT_EQ(st.faces_copied, textured);
    EXPECT_EQ(st.faces_resampled, 0u);
    EXPECT_EQ(st.texels_copied, st.texels_written);
    EXPECT_GT(st.texels_written, 0u);
    const Compared c = compare_inside(l, lay, out, static_cast<int>(shift.x()), static_cast<int>(shift.y()));
    EXPECT_GT(c.checked, textured / 2);
    EXPECT_EQ(c.differ, 0u);
  }
}

}  // namespace texdefrag::resample_test
