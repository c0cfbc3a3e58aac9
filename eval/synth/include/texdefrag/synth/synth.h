// Synthetic oblique-photogrammetry buildings with ground truth (issue 3).
//
// A generated model imitates what a multi-view-stereo export (ContextCapture, Smart3D) gives the
// pipeline: an irregular triangulation of a building and a ground patch with centimetre noise; a
// per-face view label chosen from nadir and oblique cameras by a visibility/angle/distance score
// plus noise and a few majority-vote passes; one chart per connected same-view face set, with UVs
// that are the perspective projection into that camera; charts shelf-packed into several atlas
// pages with dilated padding; every chart has its own copies of its vertices, as real exports do.
// The ground truth real data lacks (plane id and semantic class per face, the view per face, the
// cameras) is returned beside the mesh and written as a JSON sidecar.
//
// Determinism: every random number comes from std::mt19937_64 (whose output sequence the C++
// standard fixes) through distributions implemented here, never std::*_distribution (whose
// outputs differ between standard libraries). Same options and seed => bit-identical files on any
// conforming compiler/library with IEEE doubles and the same floating-point contraction settings.
#pragma once

#include "texdefrag/core/mesh.h"
#include "texdefrag/io/image.h"

#include <nlohmann/json.hpp>

#include <array>
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

namespace texdefrag::synth {

enum class Archetype { Residential, Factory, Hotel, LShape, Courtyard, Mixed };

/// Semantic class of a face. The numeric values are the ones written to the truth JSON.
enum class SemanticClass : uint8_t { Wall = 0, Roof = 1, Ground = 2, Detail = 3, Vegetation = 4 };

/// "residential", "factory", "hotel", "lshape", "courtyard", "mixed".
const char* to_string(Archetype a);
/// "wall", "roof", "ground", "detail", "vegetation".
const char* to_string(SemanticClass c);
/// Parses an archetype name (as printed by to_string). Returns nullopt for an unknown name.
std::optional<Archetype> parse_archetype(const std::string& name);

struct SynthOptions {
  /// Building type; Mixed picks one of the five from the seed.
  Archetype archetype = Archetype::Mixed;
  /// Requested number of triangles, in [1000, 5,000,000]; the result is within a few percent.
  size_t target_faces = 20000;
  /// Seed of every random choice (shape, sizes, triangulation, noise, views, colours).
  uint64_t seed = 1;
  /// Standard deviation of the Gaussian noise added to each vertex position, centimetres, >= 0.
  double noise_cm = 2.0;
  /// Number of small holes cut into the surface (radius 0.3-0.8 m), >= 0.
  int holes = 2;
  /// Amplitude of spatially smooth noise (2.5 m value noise, one field per camera) on the log view
  /// scores, >= 0: makes irregular patches. The defaults match ContextCapture L18 tiles' charts.
  double view_noise = 0.5;
  /// Standard deviation of independent per-(face, camera) noise on the log view scores, >= 0:
  /// scattered one- and two-triangle charts. Larger values give more fragmented charts.
  double view_noise_iid = 0.1;
  /// Majority-vote passes over face neighbours after view selection, >= 0.
  int smoothing_passes = 1;
  /// Mean texture resolution, texels per mean triangle edge, > 0 (ContextCapture's coarse tiles
  /// have triangles a few texels across).
  double texels_per_edge = 7.0;
  /// Padding around each chart in the atlas, texels, in [1, 8]; filled by dilation.
  int padding = 2;
  /// Side of an atlas page, texels, power of two in [256, 8192]. The last page is trimmed.
  int page_size = 1024;
  /// When false, pages keep their size but no colours are rendered (faster; tests of geometry).
  bool render_pages = true;

  // Features of real photogrammetry exports that make defragmentation hard (docs/synth.md, "The
  // hard preset"); all off by default, so the default buildings stay as they were.
  /// Share of the faces, in [0, 1], in charts whose UVs are mirrored (u -> -u) relative to the
  /// others, 3D winding unchanged: their signed UV area has the opposite sign. Charts are drawn at
  /// random until the share is reached (exact within one chart).
  double mirror_fraction = 0;
  /// Share of the faces, in [0, 0.5], whose three UV corners are one point (zero UV area), each
  /// such face with its own texture coordinates at its first corner's UV.
  double zero_uv_fraction = 0;
  /// Share of the charts, in [0, 0.5], laid over a larger chart of the same page (input UV overlaps;
  /// the later chart's colours win where they overlap).
  double overlap_fraction = 0;
  /// Perspective texel-density gradient inside each chart, in [0, 1.5]: a 2D homography with
  /// density ratio (1 + g/2) / (1 - g/2) across the chart along a random direction.
  double perspective = 0;
  /// Standard deviation, in [0, 1], of the natural log of a per-chart texel-density factor
  /// (density jumps between neighbouring charts beyond the cameras' own).
  double density_jitter = 0;
  /// Standard deviation, in [0, 0.5], of a per-chart exposure factor (brightness steps at seams
  /// beyond the cameras' own exposures).
  double exposure_sd = 0;
  /// Share of the surface area, in [0, 0.8], given to trees (class vegetation) and ground clutter
  /// (cars, bins, bushes: class detail) on the ground patch around the building.
  double clutter_fraction = 0;
  /// Probability, in [0, 1], that a face whose neighbour lies on another plane takes that
  /// neighbour's view (when the view sees it): more charts crossing plane boundaries.
  double cross_plane = 0;
};

/// Named option sets. "default": SynthOptions{} as is. "hard": the features of real
/// ContextCapture tiles (mirrored charts, zero-UV-area faces, overlaps, density gradients and
/// jumps, exposure steps, trees and clutter, charts across planes) with fragmentation matched to
/// the real tiles (docs/synth.md, realism table). Returns false for an unknown name.
bool apply_preset(const std::string& name, SynthOptions& options);
/// Names accepted by apply_preset.
std::vector<std::string> preset_names();

/// A pinhole camera. Pixel (x right, y down) of a world point p:
/// q = R (p - position); x = cx + focal_px * q.x / q.z; y = cy + focal_px * q.y / q.z (q.z > 0).
struct Camera {
  std::string kind;                  ///< "nadir" or "oblique_n|e|s|w"
  Vec3 position = Vec3::Zero();      ///< metres
  std::array<Vec3, 3> rotation{};    ///< rows of R: right, down, forward (unit, orthonormal)
  double focal_px = 0;               ///< focal length, pixels
  int width = 0, height = 0;         ///< image size, pixels; principal point at the centre
  double texel_scale = 0;            ///< atlas texels per image pixel for charts of this camera
  double exposure = 1;               ///< multiplicative brightness of this camera's texels
  Vec3 colour_gain = Vec3::Ones();   ///< per-channel gain (white balance shift)
};

/// One plane (or curved surface) of the building model.
struct PlaneInfo {
  SemanticClass semantic = SemanticClass::Wall;
  Vec3 normal = Vec3::UnitZ();  ///< unit, outward; for curved surfaces the mean normal
  double offset = 0;            ///< normal . x = offset for points x on the plane, metres
  bool curved = false;          ///< true for the facets of a cylinder (one id for the whole surface)
};

/// Ground truth of a generated model; per-face arrays follow TexturedMesh::faces.
struct SynthTruth {
  std::string archetype;                   ///< the archetype actually generated (never "mixed")
  std::vector<int> face_plane;             ///< index into planes
  std::vector<SemanticClass> face_class;   ///< semantic class of the face's plane
  std::vector<int> face_view;              ///< index into cameras
  std::vector<int> face_chart;             ///< chart (connected same-view component) of each face
  std::vector<PlaneInfo> planes;
  std::vector<Camera> cameras;
  int num_charts = 0;
  size_t welded_vertices = 0;              ///< distinct 3D vertices before per-chart duplication
  double mean_edge_m = 0;                  ///< target edge length used by the triangulation, metres
  double texels_per_metre = 0;             ///< mean atlas resolution
  /// Per face (output order): 1 when its chart's UVs are mirrored (mirror_fraction).
  std::vector<uint8_t> face_mirrored;
  /// Per face: 1 when its UV area is zero by construction (zero_uv_fraction).
  std::vector<uint8_t> face_zero_uv;
  /// Charts laid over another chart (overlap_fraction): (chart, host chart) pairs.
  std::vector<std::array<int, 2>> overlapping_charts;
  /// Per chart (face_chart index): its own exposure factor (exposure_sd; 1 when off).
  std::vector<double> chart_exposure;
  /// Faces on trees and ground clutter (clutter_fraction).
  size_t clutter_faces = 0;
  /// Edges between faces of two different planes (manifold edges only), and those of them inside
  /// a chart (both faces in the same chart): charts crossing plane boundaries (cross_plane).
  size_t plane_edges = 0, plane_edges_in_chart = 0;
};

struct SynthModel {
  std::string name;          ///< file stem used by write_model
  TexturedMesh mesh;         ///< pages' image_path are bare file names until write_model sets them
  std::vector<Image> pages;  ///< one RGB image per mesh page (empty pixels if !render_pages)
  SynthTruth truth;
};

/// Generates one building. Throws std::invalid_argument for options outside their ranges.
SynthModel generate(const SynthOptions& options);

/// The truth sidecar as JSON: classes, per-face plane/class/view/chart, planes, cameras, options.
nlohmann::json truth_json(const SynthModel& model, const SynthOptions& options);

/// Writes out_dir/<model.name>.obj, .mtl, <name>_<k>.jpg pages and <name>.truth.json, creating
/// out_dir. Updates model.mesh.pages[k].image_path to the written files. Throws on I/O errors.
/// jpeg_quality in [1, 100].
void write_model(SynthModel& model, const SynthOptions& options, const std::string& out_dir,
                 int jpeg_quality = 90);

struct DatasetOptions {
  size_t count = 187;           ///< number of buildings, >= 1 (the paper evaluates 187)
  uint64_t seed = 1;            ///< dataset seed; building i uses a seed derived from it and i
  size_t min_faces = 5000;      ///< face counts are log-uniform in [min_faces, max_faces]
  size_t max_faces = 200000;
  double noise_cm = 2.0;        ///< as SynthOptions::noise_cm
  bool render_pages = true;     ///< as SynthOptions::render_pages
  /// Every building's options start from this (e.g. a preset); archetype, target_faces, seed,
  /// noise_cm, holes and render_pages are then set per building.
  SynthOptions base;
  /// Name of the preset `base` came from, written to the manifest.
  std::string preset = "default";
};

/// The per-building options of a data set (archetype, size, seed), without generating anything.
std::vector<SynthOptions> dataset_plan(const DatasetOptions& options);

/// Generates a data set: out_dir/<name>/<name>.obj ... for each planned building, plus
/// out_dir/manifest.json listing OBJ and truth paths (relative to out_dir) and parameters.
/// `progress` (may be empty) is called after each building with (done, total). Returns the manifest.
nlohmann::json write_dataset(const DatasetOptions& options, const std::string& out_dir,
                             const std::function<void(size_t, size_t)>& progress = {});

}  // namespace texdefrag::synth
