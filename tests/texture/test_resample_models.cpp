// Invariants of texture resampling on the real models (skipped when ../shared/data is absent):
// laying every chart out where it was (identity) or moved by whole texels onto a larger page
// copies every face bit-exact, so every texel whose centre lies inside a triangle equals the input
// texel it came from; a sub-texel shift resamples every face and stays close to the input.
#include "resample_models_util.h"
#include "texdefrag/testing/fixtures.h"

#include <gtest/gtest.h>

#include <cstdio>

namespace texdefrag {
namespace {

using namespace resample_test;

TEST(TextureResampleModels, IdentityAndWholeTexelShiftsAreBitExact) {
  const auto models = testing::real_models(10000);
  if (models.empty()) GTEST_SKIP() << "no real models under ../shared/data";
  for (const std::string& path : models) expect_whole_texel_layouts_bit_exact(path);
}

TEST(TextureResampleModels, SubTexelShiftResamplesCloseToInput) {
  const auto models = testing::real_models(3000);
  if (models.empty()) GTEST_SKIP() << "no real models under ../shared/data";
  const Loaded l = load(models.front());
  const Layout lay = shifted_layout(l, Vec2(0.25, 0.5), 0);
  ResampleStats st;
  const auto out = resample_atlas(l.mesh, l.pages, l.charts.atlas, lay, ResampleOptions{}, &st);
  EXPECT_EQ(st.faces_copied, 0u);
  // Inside the triangles, bilinear at a (0.25, 0.5)-texel offset is a mild blur of the input:
  // compare with the input texel at the same place, and with the input shifted by two texels
  // (what a wrong map would give).
  const Compared c = compare_inside(l, lay, out, 0, 0);
  ASSERT_GT(c.checked, 1000u);
  const auto mean = [](const Compared& x) { return x.sum_abs / static_cast<double>(x.checked); };
  Layout two = shifted_layout(l, Vec2(0, 0), 0);
  const Compared wrong = compare_inside(l, two, l.pages, 2, 2);
  std::printf("mean |difference| inside triangles: %.2f (input vs itself shifted by 2 texels: %.2f)\n", mean(c), mean(wrong));
  EXPECT_LT(mean(c), 0.5 * mean(wrong));
}

}  // namespace
}  // namespace texdefrag
