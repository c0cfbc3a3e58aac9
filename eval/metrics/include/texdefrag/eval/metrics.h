// Evaluation metrics of texture defragmentation (../shared/docs/METHOD.md section 3; key names and
// conventions in docs/eval.md).
//
// Per model (input or output of any tool): counts, charts, seam lengths, texture size, packing
// efficiency and UV overlaps. Per comparison: faces matched by their 3D triangle (not by index, so
// outputs of other programs that reorder or drop faces can be evaluated), distortion of the UV map
// input -> output, and texture fidelity (PSNR of surface samples, fraction copied without resampling).
//
// Conventions:
// - Pages that name the same image file are one page (MeshLab, which writes the M-method's outputs,
//   gives one image to several materials); canonical_pages() does this before any metric.
// - UV lengths and areas are in texels of each face's own page. For an output that is the output's
//   texels; a tool that keeps texel density (ours, the M-method) has output texels = input texels.
#pragma once

#include "texdefrag/core/mesh.h"
#include "texdefrag/core/topology.h"
#include "texdefrag/eval/appearance.h"
#include "texdefrag/io/image.h"

#include <nlohmann/json.hpp>

#include <array>
#include <cstdint>
#include <string>
#include <vector>

namespace texdefrag::eval {

// ---------------------------------------------------------------------------------------------
// Per-model metrics

/// Metrics of one model. Every count is over the faces of the mesh as given (nothing is dropped).
struct ModelMetrics {
  size_t faces = 0;              ///< triangles
  size_t textured_faces = 0;     ///< triangles with a page
  size_t v3 = 0;                 ///< distinct 3D positions referenced by faces (bit-exact)
  size_t v2 = 0;                 ///< distinct (position, u, v, page) corners of textured faces
  double vertex_replication = 0; ///< v2 / v3 (0 when v3 = 0)
  size_t charts = 0;             ///< components of textured faces over UV-continuous edges
  size_t zero_area_charts = 0;   ///< charts whose UV area is exactly 0
  size_t charts_nonzero = 0;     ///< charts - zero_area_charts
  double uv_border_length = 0;   ///< texels: every border edge of every chart (both sides of a seam, plus boundary)
  size_t seam_edges = 0;         ///< welded edges with two textured faces that are not UV-continuous
  double seam_length_3d = 0;     ///< model units: seam edges counted once, mesh boundary excluded
  size_t pages = 0;              ///< distinct page images
  double megapixels = 0;         ///< sum over pages of width*height / 1e6
  uint64_t page_bytes = 0;       ///< sum of the page files' sizes on disk
  size_t missing_page_files = 0; ///< pages whose file does not exist (not in page_bytes)
  double uv_area = 0;            ///< texels^2: sum of |UV area| of textured faces
  double page_area = 0;          ///< texels^2: sum over pages of width*height
  double packing_efficiency = 0; ///< uv_area / page_area (0 when page_area = 0)
  size_t uv_overlaps = 0;        ///< pairs of same-page UV triangles whose interiors intersect
  TopologyReport topology;       ///< defects of the welded mesh (see core/topology.h)
};

/// A copy of `mesh` in which pages naming the same image file (after path normalisation) are one
/// page; faces and materials are unchanged except Face::page. Pages keep their first order.
/// @param mesh  any mesh; page sizes are copied as they are.
TexturedMesh canonical_pages(const TexturedMesh& mesh);

/// Computes all per-model metrics. Pages are canonicalised first (canonical_pages).
/// @param mesh  the model; every page used by a face must have a known size (width, height > 0),
///              else std::invalid_argument naming the page. Page files are only stat'ed, not read.
ModelMetrics model_metrics(const TexturedMesh& mesh);

/// Number of pairs of triangles whose interiors intersect. Triangles sharing only an edge or a
/// vertex do not overlap; triangles of zero area (exactly collinear corners) never count.
/// Exact: orientation predicates with an exact fallback. Broad phase: a uniform grid; O(n) for
/// evenly sized triangles (100k triangles in well under a second).
/// @param tris  triangles in any 2D units (for an atlas: texels of one page); may be empty.
size_t count_overlapping_pairs(const std::vector<std::array<Vec2, 3>>& tris);

/// UV overlaps of a mesh: count_overlapping_pairs over the textured faces of each page (texels).
/// @param mesh  pages canonicalised by the caller when several materials share an image.
size_t count_uv_overlaps(const TexturedMesh& mesh);

/// Sign of the orientation of (a, b, c): +1 counter-clockwise, -1 clockwise, 0 collinear. Exact for
/// all finite inputs (floating-point filter, then exact expansion arithmetic).
int orient2d(const Vec2& a, const Vec2& b, const Vec2& c);

/// True when the interiors of two non-degenerate triangles intersect (exact).
/// @param a, b  triangles, any orientation; callers must exclude zero-area ones.
bool triangle_interiors_overlap(const std::array<Vec2, 3>& a, const std::array<Vec2, 3>& b);

// ---------------------------------------------------------------------------------------------
// Face matching

struct MatchOptions {
  /// Model units. An output position that is not bit-identical to an input position is identified
  /// with the nearest input position within this distance (MeshLab, which writes the M-method's
  /// outputs, prints "%f": 6 decimals, error <= 5e-7). 0 identifies bit-identical positions only.
  double position_tolerance = 1e-5;
};

/// Correspondence between the faces of an input and an output, by 3D triangle.
struct FaceMatch {
  std::vector<int> output_of_input;  ///< per input face: matched output face, -1 when lost
  std::vector<int> input_of_output;  ///< per output face: matched input face, -1 when added
  /// Per input face: for input corner k, the output corner (0..2) at the same 3D position; {-1,-1,-1}
  /// when lost.
  std::vector<std::array<int, 3>> output_corner;
  size_t matched = 0;
  size_t lost = 0;                   ///< input faces with no output face
  size_t added = 0;                  ///< output faces with no input face
  size_t lost_degenerate = 0;        ///< lost faces with two corners at one position
  size_t lost_zero_area = 0;         ///< lost, not degenerate, 3D area exactly 0
  size_t lost_non_manifold = 0;      ///< lost, none of the above, with an edge shared by > 2 faces
  size_t lost_other = 0;             ///< lost for any other reason
  size_t exact_positions = 0;        ///< distinct output positions bit-identical to an input position
  size_t snapped_positions = 0;      ///< distinct output positions identified within the tolerance
  size_t moved_positions = 0;        ///< distinct output positions that are no input position
};

/// Matches faces by their three 3D positions as an unordered set (multiset matching: repeated
/// triangles are paired in face order). Output positions are first identified with input positions
/// (bit-exact, else within options.position_tolerance).
/// @param in, out  the meshes; any faces, any order.
FaceMatch match_faces(const TexturedMesh& in, const TexturedMesh& out, const MatchOptions& options = {});

// ---------------------------------------------------------------------------------------------
// Comparison: distortion and texture fidelity

/// Distortion of the map from input UVs (input texels) to output UVs (output texels) over matched
/// faces textured on both sides (core/distortion.h measures). An output chart that is a mirror image
/// of its input over most of its area is measured through the mirror y -> -y (a reflected chart
/// with reflected texture looks the same on the surface; MeshLab-written M-method outputs are
/// mirrored everywhere); its faces that still reverse orientation are counted as flipped.
struct DistortionMetrics {
  size_t faces = 0;              ///< faces measured (matched, textured in both)
  size_t mirrored_charts = 0;    ///< output charts measured through the mirror
  size_t mirrored_faces = 0;     ///< measured faces in mirrored charts
  double arap = 0;               ///< area-weighted mean of (s1-1)^2 + (s2-1)^2, flipped faces included
  double symmetric_dirichlet = 0;///< area-weighted mean of s1^2+s2^2+s1^-2+s2^-2 over non-flipped faces
  size_t flipped = 0;            ///< faces whose map reverses orientation or collapses (det J <= 0)
  size_t zero_area_input = 0;    ///< faces with zero input UV area (weight 0, not in the means)
  double weight = 0;             ///< texels^2: total input UV area of the measured faces
};

/// Distortion over matched faces. `in`, `out` with pages canonicalised and sizes known.
/// @param match  from match_faces(in, out).
DistortionMetrics uv_distortion(const TexturedMesh& in, const TexturedMesh& out, const FaceMatch& match);

struct FidelityOptions {
  /// Target number of surface samples over all measured faces, spread proportionally to input UV
  /// area; every face of non-zero UV area gets at least one and a face gets a square number of
  /// samples, so the actual count differs (t078_L15: 1000000 asked, 856622 taken).
  size_t samples = 1000000;
  /// Largest per-face subdivision m (a face gets m^2 samples): caps the samples of one face.
  int max_subdivision = 32;
  /// Texels: how far output UVs may be from an exact whole-texel translation/90-degree rotation of
  /// the input UVs for the face to count as copied (OBJ writers round UVs: "%f" on a 4096 page is
  /// off by up to 0.002 texel).
  double rigid_tolerance = 0.01;
};

struct FidelityMetrics {
  size_t faces = 0;             ///< faces sampled (matched, textured in both, non-zero input UV area)
  size_t samples = 0;           ///< sample points taken
  double weight = 0;            ///< texels^2: input UV area of the sampled faces
  double mse = 0;               ///< area-weighted mean squared RGB difference (8-bit levels^2)
  double psnr_db = 0;           ///< 10 log10(255^2 / mse); +infinity when mse = 0
  double copied_fraction = 0;   ///< area fraction whose samples were copied without resampling
  double rigid_fraction = 0;    ///< area fraction of faces whose map is a whole-texel map
  size_t rigid_faces = 0;       ///< faces whose map is a whole-texel map (see texture_fidelity)
};

/// Texture fidelity: colours at deterministic stratified surface samples read bilinearly through
/// input UVs on input pages and through output UVs on output pages. A face's map is "whole-texel"
/// when it is a symmetry of the texel grid (rotation by a multiple of 90 degrees, optionally
/// mirrored) plus an integer translation, within options.rigid_tolerance. A sample is "copied" when
/// its face's map is whole-texel and the input texel holding the sample equals (R, G and B
/// bit-identical) the output texel it maps to.
/// @param in_pages   one image per page of `in` (canonicalised), 1-4 channels (grey is replicated)
/// @param out_pages  one image per page of `out`
FidelityMetrics texture_fidelity(const TexturedMesh& in, const std::vector<Image>& in_pages,
                                 const TexturedMesh& out, const std::vector<Image>& out_pages,
                                 const FaceMatch& match, const FidelityOptions& options = {});

/// Reads every page image of `mesh` (read_image); throws ImageError naming the file.
std::vector<Image> load_pages(const TexturedMesh& mesh);

struct EvalOptions {
  MatchOptions match;
  FidelityOptions fidelity;
  /// Compute texture fidelity (reads every page image); when false `fidelity` stays zero and the
  /// image-based appearance measures (seam colour, rendered views) are skipped too.
  bool texture = true;
  /// Appearance measures (appearance.h): texel clashes per MIP level (needs no image), seam colour
  /// discrepancy and rendered-view fidelity (need the images). False skips all three.
  bool appearance = true;
  /// Texel clashes and seam colour discrepancy at MIP levels 0..clash_max_level (>= 0).
  int clash_max_level = 4;
  /// Views, sizes (distance steps) and reference supersampling of the rendered-view fidelity.
  RenderFidelityOptions render;
};

/// Everything eval reports for one input/output pair.
struct Comparison {
  std::string input_path, output_path;  ///< as given (may be empty for in-memory meshes)
  ModelMetrics input, output;
  FaceMatch match;
  DistortionMetrics distortion;
  bool has_fidelity = false;
  FidelityMetrics fidelity;
  bool has_clashes = false;                           ///< EvalOptions::appearance
  std::vector<ClashLevel> clashes_input, clashes_output;
  bool has_seam_colour = false;                       ///< appearance and texture
  SeamColourMetrics seam_colour_input, seam_colour_output;
  bool has_rendered = false;                          ///< appearance and texture
  RenderFidelity rendered;
};

/// Compares two meshes already in memory. Pages are canonicalised; images are read from the
/// pages' paths when options.texture is set.
Comparison compare(const TexturedMesh& in, const TexturedMesh& out, const EvalOptions& options = {});

/// Reads both models, each in any built-in format (io/model_format.h: OBJ, OSGB, glTF/GLB; pages
/// embedded in the model are decoded and read losslessly), and compares them. Throws the readers'
/// errors (ObjError, FormatError, ImageError) naming the file.
Comparison compare_files(const std::string& in_path, const std::string& out_path, const EvalOptions& options = {});

// ---------------------------------------------------------------------------------------------
// Reports

/// JSON of one model's metrics (key names in docs/eval.md).
nlohmann::json to_json(const ModelMetrics& m);
/// JSON of a comparison: input, output, relative_change, matching, distortion, fidelity.
/// Non-finite numbers (PSNR of identical textures) are written as null.
nlohmann::json to_json(const Comparison& c);
/// (out - in) / in, or NaN when in = 0 (written as null in JSON).
double relative_change(double in, double out);
/// Fixed-format human-readable summary, one line per group of metrics, ending with a newline.
std::string summary(const Comparison& c);

}  // namespace texdefrag::eval
