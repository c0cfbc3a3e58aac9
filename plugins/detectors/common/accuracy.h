// Per-face plane labelling accuracy of a detection against ground-truth plane ids.
#pragma once

#include <vector>

namespace texdefrag::detectors {

struct SegmentationScore {
  double accuracy = 0;      ///< matched-overlap accuracy in [0, 1], see score_segmentation
  int truth_planes = 0;     ///< distinct truth ids among the counted faces
  int regions = 0;          ///< distinct region ids among the counted faces
  int over_segmented = 0;   ///< truth planes with >= 2 regions each covering >= `share` of the plane
  int under_segmented = 0;  ///< regions with >= 2 truth planes each covering >= `share` of the region
  long long faces = 0;      ///< counted faces (truth >= 0 and region >= 0)
};

/// Scores a face labelling. Regions and truth planes are matched one to one, greedily by largest
/// face overlap; accuracy = faces in matched overlaps / counted faces. A plane split in two loses
/// the smaller part, two planes in one region lose the smaller plane, so both over- and
/// under-segmentation lower it.
/// region, truth: per face, same size; negative ids are not counted.
/// share: fraction in (0, 1] for the over/under-segmentation counts (default 0.05).
SegmentationScore score_segmentation(const std::vector<int>& region, const std::vector<int>& truth,
                                     double share = 0.05);

}  // namespace texdefrag::detectors
