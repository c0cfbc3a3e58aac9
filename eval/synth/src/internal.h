// Internals of the synthetic building generator, shared by its source files (not installed).
#pragma once

#include "texdefrag/synth/synth.h"

#include <cmath>
#include <cstdint>
#include <random>
#include <vector>

namespace texdefrag::synth::detail {

/// Portable random numbers: std::mt19937_64 (sequence fixed by the standard) with distributions
/// written out here, because std::uniform_real_distribution / normal_distribution may produce
/// different values with different standard libraries.
class Rng {
 public:
  /// seed: any value; stream: decorrelates generators of different generation steps.
  explicit Rng(uint64_t seed, uint64_t stream = 0) : engine_(mix(seed ^ mix(stream + 0x9E3779B97F4A7C15ull))) {}
  /// Uniform in [0, 1), 53 random bits.
  double uniform() { return static_cast<double>(engine_() >> 11) * (1.0 / 9007199254740992.0); }
  /// Uniform in [lo, hi).
  double uniform(double lo, double hi) { return lo + (hi - lo) * uniform(); }
  /// Uniform integer in [lo, hi] (inclusive); hi >= lo. Bias below 2^-40 for ranges < 2^24.
  int uniform_int(int lo, int hi) {
    const uint64_t n = static_cast<uint64_t>(static_cast<int64_t>(hi) - lo + 1);
    return lo + static_cast<int>(engine_() % n);
  }
  /// True with probability p.
  bool chance(double p) { return uniform() < p; }
  /// Standard normal by the Box-Muller transform (one value per call, the pair's second dropped).
  double normal() {
    double u1 = uniform();
    if (u1 < 1e-300) u1 = 1e-300;
    const double u2 = uniform();
    return std::sqrt(-2.0 * std::log(u1)) * std::cos(6.283185307179586 * u2);
  }
  uint64_t next() { return engine_(); }

  /// SplitMix64 finaliser: a well-mixed 64-bit hash.
  static uint64_t mix(uint64_t z) {
    z += 0x9E3779B97F4A7C15ull;
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
  }

 private:
  std::mt19937_64 engine_;
};

/// Smooth value noise in [0, 1] at p / scale (trilinear interpolation of hashed lattice values).
inline double value_noise(const Vec3& p, double scale, uint64_t salt) {
  const Vec3 q = p / scale;
  const double fx = std::floor(q.x()), fy = std::floor(q.y()), fz = std::floor(q.z());
  const double tx = q.x() - fx, ty = q.y() - fy, tz = q.z() - fz;
  auto h = [&](double x, double y, double z) {
    const uint64_t k = Rng::mix(salt ^ Rng::mix(static_cast<uint64_t>(static_cast<int64_t>(x)) ^
                                                Rng::mix(static_cast<uint64_t>(static_cast<int64_t>(y)) ^
                                                         Rng::mix(static_cast<uint64_t>(static_cast<int64_t>(z))))));
    return static_cast<double>(k >> 11) * (1.0 / 9007199254740992.0);
  };
  auto s = [](double t) { return t * t * (3 - 2 * t); };
  const double sx = s(tx), sy = s(ty), sz = s(tz);
  double r = 0;
  for (int dz = 0; dz < 2; ++dz)
    for (int dy = 0; dy < 2; ++dy)
      for (int dx = 0; dx < 2; ++dx)
        r += (dx ? sx : 1 - sx) * (dy ? sy : 1 - sy) * (dz ? sz : 1 - sz) * h(fx + dx, fy + dy, fz + dz);
  return r;
}

/// One planar polygon of the building model: an outer ring and holes, all on one plane.
/// Ring orientation is free; the visible side is given by `normal`.
struct Polygon {
  std::vector<Vec3> outer;
  std::vector<std::vector<Vec3>> holes;
  Vec3 normal = Vec3::UnitZ();  ///< unit, the visible (outward) side
  int plane = 0;                ///< index into Shape::planes
};

/// The building before meshing: planar polygons, the planes they lie on, and facts about it.
struct Shape {
  std::string archetype;
  std::vector<Polygon> polygons;
  std::vector<PlaneInfo> planes;
  std::vector<uint8_t> plane_glass;  ///< per plane: 1 for window panes (coloured as glass)
  Vec3 bbox_min = Vec3::Zero(), bbox_max = Vec3::Zero();  ///< of the building (ground excluded)
  int clutter_planes_from = -1;  ///< planes from this index on are trees and clutter (-1: none)
};

/// Builds the polygons of one building of the given archetype (not Mixed), ground patch included.
/// scale in [0.8, 2] stretches the footprint (bigger buildings for bigger face counts).
Shape build_shape(Archetype archetype, Rng& rng, double scale);

/// Adds trees and ground clutter on the ground patch outside the building's bounding box until
/// they hold `fraction` of the total surface area (clutter.cpp); nothing when fraction <= 0.
void add_clutter(Shape& shape, double fraction, Rng& rng);

/// Result of meshing a Shape: a welded triangle mesh with per-face truth.
struct RawMesh {
  std::vector<Vec3> positions;
  std::vector<std::array<int, 3>> tris;  ///< counter-clockwise seen from the visible side
  std::vector<int> face_plane;
};

/// Meshes every polygon with target edge `edge` metres (jittered grid + Delaunay), sharing the
/// points of common polygon edges so neighbouring planes join. Returns the predicted face count
/// without triangulating when `count_only`.
size_t remesh(const Shape& shape, double edge, Rng& rng, RawMesh* out);

/// Adds Gaussian noise (sigma metres) to every position and cuts `holes` small holes.
void perturb(RawMesh& mesh, const Shape& shape, double sigma, int holes, Rng& rng);

/// Cameras of an oblique flight around the shape's bounding box.
std::vector<Camera> make_cameras(const Shape& shape, Rng& rng);

/// Per-face view labels (indices into cameras) by score + noise + majority-vote smoothing.
/// noise: amplitude of spatially smooth per-camera score noise; noise_iid: of per-face noise.
/// cross_plane: probability that a face next to another plane takes that neighbour's view (drawn
/// from cross_rng only when > 0, so other streams are unchanged).
std::vector<int> select_views(const RawMesh& mesh, const Shape& shape, const std::vector<Camera>& cameras,
                              double noise, double noise_iid, int passes, Rng& rng, double cross_plane, Rng& cross_rng);

/// Projects p into camera c: pixel coordinates (x right, y down); false behind the camera.
bool project(const Camera& c, const Vec3& p, Vec2& pixel);

/// Builds charts, UVs, pages and colours into `model` (mesh, pages, truth.face_* in output order).
/// Needs model.name and model.truth.cameras (with texel_scale) set.
void build_atlas(const RawMesh& raw, const Shape& shape, const std::vector<int>& views, const SynthOptions& options,
                 Rng& rng, SynthModel& model);

}  // namespace texdefrag::synth::detail
