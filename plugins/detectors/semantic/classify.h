// Semantic classes of faces from geometry alone: ground, vegetation, building, other.
//
// Urban photogrammetry tiles hold streets, lawns, trees and cars around the buildings. Liu et al.
// 2024 (section 5, future work) suggest semantic constraints so that charts never join a facade
// with the street in front of it or a tree. No labels come with a ContextCapture tile, so the
// classes are estimated from the geometry (after the rule-based urban classifiers of airborne
// LiDAR, e.g. progressive morphological ground filtering, Zhang et al. 2003, IEEE TGRS 41(4)):
// 1. ground surface: lowest points per grid cell, opened (erosion then dilation) with a window wider
//    than the buildings, so roofs do not count as ground; height above ground per face;
// 2. patch features per face over its k-ring: normal scatter (1 - |mean unit normal|, 0 on a plane)
//    and coherence (area fraction of the patch whose normal is within 20 deg of the face's: near 1
//    on a plane, >= 1/2 beside a crease between two planes, low in a tree crown);
// 3. rules: low and near-horizontal -> ground; rough above ground -> vegetation; smooth surfaces
//    form building candidates, a connected candidate is a building when it is tall and large
//    enough and mostly made of large planes (walls, roofs), vegetation when tall and large but not
//    planar (tree crowns simplified into smooth blobs), else `other` (cars, walls, kerbs); small
//    islands of a class take their neighbours'.
// Units: heights and areas are in model units and assume metres (ContextCapture and glTF are).
#pragma once

#include "texdefrag/core/mesh.h"
#include "texdefrag/core/topology.h"

#include <array>
#include <string>
#include <vector>

namespace texdefrag::detectors::semantic {

enum class FaceClass : int { Ground = 0, Vegetation = 1, Building = 2, Other = 3 };
constexpr int kNumClasses = 4;
/// "ground", "vegetation", "building", "other".
const char* class_name(FaceClass c);

struct ClassifyOptions {
  Vec3 up = Vec3::UnitZ();             ///< unit vertical direction of the model
  double ground_cell = 2.0;            ///< ground grid cell side, metres (> 0)
  double ground_window = 40.0;         ///< opening window side, metres: wider than the widest building
  double ground_height = 0.8;          ///< faces below this height above ground may be ground, metres
  double ground_slope_deg = 30.0;      ///< ground faces are within this angle of horizontal, degrees
  int patch_rings = 2;                 ///< k-ring of the patch features (>= 1)
  double vegetation_scatter = 0.15;    ///< a rough patch has a normal scatter above this, [0, 1]
  double vegetation_coherence = 0.45;  ///< and less than this area fraction within 20 deg of the face's normal
  double building_min_height = 2.5;    ///< a building reaches at least this height above ground, metres
  double building_min_area = 15.0;     ///< a building's smooth surface covers at least this area, m^2
  double plane_angle_deg = 15.0;       ///< a planar patch holds faces within this angle of its seed's normal, degrees
  double plane_min_area = 8.0;         ///< patches at least this large count as planes, m^2
  double building_min_planar_fraction = 0.5;  ///< a building has at least this area fraction in such planes
  int min_component_faces = 30;        ///< smaller same-class islands take their neighbours' class
  int normal_filter_iterations = 3;    ///< bilateral normal filter passes before the features
};

struct Classification {
  std::vector<FaceClass> face_class;   ///< one per face (untextured faces are classified too)
  std::vector<double> height;          ///< height above the ground estimate, per face, metres
  std::vector<double> scatter;         ///< normal scatter per face, [0, 1]
  std::vector<double> coherence;       ///< area fraction of the patch within 20 deg of the face's normal
  std::array<size_t, kNumClasses> faces_per_class{};
  std::array<double, kNumClasses> area_per_class{};
  int building_components = 0;         ///< connected building parts
  int relabelled_islands = 0;          ///< islands that took their neighbours' class
  int nonplanar_components = 0;        ///< tall, large smooth components read as vegetation (not planar)
};

/// Classifies every face. mesh/topo: the model and its welded topology (faces adjacent through any
/// welded edge, manifold or not, are neighbours). Deterministic; O(F * rings^2).
Classification classify_faces(const TexturedMesh& mesh, const Topology& topo, const ClassifyOptions& options);

/// Connected components of equal labels over edge adjacency. Returns the component per face
/// (-1 where label < 0) and their count through `count`.
std::vector<int> label_components(const Topology& topo, const std::vector<int>& label, int& count);

}  // namespace texdefrag::detectors::semantic
