// Column-profile horizon packing shared by packers.tetris (all charts) and packers.square_tetris
// (its outline tail for small charts): Lévy, Petitjean, Ray & Maillot 2002, "Least squares
// conformal maps for automatic texture atlas generation", section 5 (horizon "Tetris" packing of
// rasterised outlines), as used by the M-method (Maggiordomo et al. 2021).
//
// A chart's outline in one quarter turn is rasterised (geometry.h), dilated by the gutter and
// reduced to a bottom and a top profile per column. A page keeps its horizon H(x) (top of the
// filled area per column). A drop rests the chart where its bottom profile first touches H; its
// cost is the area wasted between H and the bottom profile plus the page area added above the
// page's current used height (rows added times page width).
#pragma once

#include "texdefrag/packers/packing.h"

#include <climits>
#include <vector>

namespace texdefrag::packing {

/// A dilated outline's column profiles (cells, relative to the padded box's lower-left corner).
struct Profile {
  int w = 0, h = 0;         ///< padded box size (cells)
  std::vector<int> bottom;  ///< lowest covered row per column, INT_MAX for an empty column
  std::vector<int> top;     ///< highest covered row + 1 per column, 0 for an empty column
  bool duplicate = false;   ///< same outline as a smaller quarter turn of the same chart
  int filled = 0;           ///< columns with a covered cell
  int bmax = 0;             ///< highest bottom among the filled columns
  long long bsum = 0;       ///< sum of the filled columns' bottoms
};

/// The profile of chart c in quarter turn q, dilated by the gutter (gutter/2 below and left,
/// the rest above and right), so the padded box is (w[q] + gutter) x (h[q] + gutter).
Profile make_profile(const PackChart& c, int q, const CommonSettings& s);

/// Profiles of chart c in its allowed quarter turns (index = turn; 4 with allow_rotation, else 1),
/// turns repeating an earlier turn's outline marked `duplicate`.
std::vector<Profile> make_profiles(const PackChart& c, const CommonSettings& s);

/// The same from the chart's raster in turn 0 (PackChart::raster(0)), when the caller has it.
std::vector<Profile> make_profiles(const Mask& raster0, const CommonSettings& s);

/// The best resting place of a profile on a horizon.
struct Drop {
  bool found = false;
  int x = 0, y = 0;    ///< padded box lower-left corner (cells)
  long long cost = 0;  ///< wasted area + added page area (cells)
  int top = 0;         ///< y + h
};

/// A page's horizon with prefix sums and scratch space (reused across drops).
struct Horizon {
  std::vector<int> H;             ///< top of the filled area per column
  std::vector<int> prefix;        ///< prefix[x] = H[0] + ... + H[x-1] (at most 32768^2 = 2^30)
  std::vector<int> lb;            ///< scratch: lower bound of the drop height per offset
  std::vector<int> wmax;          ///< scratch: window maxima of H over a profile's width
  std::vector<long long> cost_lb; ///< scratch: lower bound of the cost per offset (large pages)
  std::vector<int> cols, col_bottoms;  ///< scratch: profile columns used for the height bound
  std::vector<int> cost_lb32;     ///< scratch: lower bound of the cost per offset (pages up to 16384^2)
  /// Window maxima by powers of two, built on demand and kept up to date by place():
  /// levels[j][x] = max H[x .. x + 2^(j+1)) for x <= width - 2^(j+1).
  std::vector<std::vector<int>> levels;
  int used = 0;                   ///< highest row in use
  /// An empty horizon. width: page width in cells, > 0.
  explicit Horizon(int width);
  /// A horizon with the given column heights (e.g. a skyline's); used = max height.
  explicit Horizon(std::vector<int> heights);
  /// Recomputes prefix sums from column `from` and drops the window maxima after H was changed
  /// directly there. 0 <= from <= width.
  void update(int from);
  /// Rests profile p at drop d: H becomes the profile's top over its columns; updates `used`,
  /// the prefix sums and the window maxima.
  void place(const Profile& p, const Drop& d);
  /// max H[x .. x + 2^k) for x <= width - 2^k (k = 0: H itself); builds missing levels.
  /// 2^k <= width.
  const int* window_max(int k);
};

/// Best drop of profile p on horizon hz with rows limited to Hmax (cells), over every column
/// offset. Cost as above; ties: lower top, then leftmost. found = false when it fits nowhere.
Drop best_drop(Horizon& hz, int Hmax, const Profile& p);

}  // namespace texdefrag::packing
