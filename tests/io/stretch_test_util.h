// Shared check of the IO tests whose readers apply a node transform for measuring only
// (test_gltf, test_osgb): a model stored with a 2x stretch in x under its node ("scaled") must be
// measured like the same model stored already stretched ("prescaled"), and unlike the model
// without the stretch ("plain"), whose roof ridge the region-growing detector splits.
#pragma once

#include <nlohmann/json.hpp>

#include <gtest/gtest.h>

#include <cstddef>

namespace texdefrag::testing {

/// EXPECTs on the three best.json run reports: `stretched` positions read as stretched; the
/// detector's angle rejections, the merger's chart count and ARAP distortion and the output
/// megapixels of scaled and prescaled equal; the detector's angle rejections of plain differ.
inline void expect_stretch_measured(const nlohmann::json& scaled, const nlohmann::json& prescaled,
                                    const nlohmann::json& plain, size_t stretched) {
  EXPECT_EQ(scaled["stages"]["read"]["positions_stretched"], stretched);
  const auto& rejections = scaled["stages"]["detectors.region_growing"]["angle_rejections"];
  EXPECT_EQ(rejections, prescaled["stages"]["detectors.region_growing"]["angle_rejections"]);
  // Unscaled, the ridge is 33 degrees (split by the detector's 25-degree threshold); scaled 2x in
  // x it is 17 degrees.
  EXPECT_NE(rejections, plain["stages"]["detectors.region_growing"]["angle_rejections"]);
  for (const char* k : {"charts_out", "distortion_arap"})
    EXPECT_EQ(scaled["stages"]["mergers.arap"][k], prescaled["stages"]["mergers.arap"][k]) << k;
  EXPECT_EQ(scaled["output_stats"]["megapixels"], prescaled["output_stats"]["megapixels"]);
}

}  // namespace texdefrag::testing
