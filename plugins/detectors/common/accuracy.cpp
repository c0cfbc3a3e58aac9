#include "common/accuracy.h"

#include <algorithm>
#include <map>
#include <set>
#include <stdexcept>
#include <tuple>

namespace texdefrag::detectors {

SegmentationScore score_segmentation(const std::vector<int>& region, const std::vector<int>& truth,
                                     double share) {
  if (region.size() != truth.size())
    throw std::invalid_argument("score_segmentation: " + std::to_string(region.size()) + " regions vs " +
                                std::to_string(truth.size()) + " truth labels");
  std::map<std::pair<int, int>, long long> overlap;
  std::map<int, long long> rsize, tsize;
  SegmentationScore s;
  for (size_t f = 0; f < region.size(); ++f) {
    if (region[f] < 0 || truth[f] < 0) continue;
    ++overlap[{region[f], truth[f]}];
    ++rsize[region[f]];
    ++tsize[truth[f]];
    ++s.faces;
  }
  s.regions = static_cast<int>(rsize.size());
  s.truth_planes = static_cast<int>(tsize.size());
  if (s.faces == 0) return s;
  std::vector<std::tuple<long long, int, int>> pairs;
  for (const auto& [k, n] : overlap) pairs.emplace_back(n, k.first, k.second);
  std::sort(pairs.begin(), pairs.end(), [](const auto& a, const auto& b) {
    if (std::get<0>(a) != std::get<0>(b)) return std::get<0>(a) > std::get<0>(b);
    return std::make_pair(std::get<1>(a), std::get<2>(a)) < std::make_pair(std::get<1>(b), std::get<2>(b));
  });
  std::set<int> used_r, used_t;
  long long matched = 0;
  for (const auto& [n, r, t] : pairs) {
    if (used_r.count(r) || used_t.count(t)) continue;
    used_r.insert(r);
    used_t.insert(t);
    matched += n;
  }
  s.accuracy = static_cast<double>(matched) / static_cast<double>(s.faces);
  std::map<int, int> parts_of_truth, parts_of_region;
  for (const auto& [k, n] : overlap) {
    if (static_cast<double>(n) >= share * static_cast<double>(tsize[k.second])) ++parts_of_truth[k.second];
    if (static_cast<double>(n) >= share * static_cast<double>(rsize[k.first])) ++parts_of_region[k.first];
  }
  for (const auto& [t, c] : parts_of_truth) s.over_segmented += c >= 2;
  for (const auto& [r, c] : parts_of_region) s.under_segmented += c >= 2;
  return s;
}

}  // namespace texdefrag::detectors
