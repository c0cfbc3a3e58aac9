// Model formats: one reader/writer per file format behind one interface, chosen by the input file.
// The pipeline reads through `format_for_input(path).read(...)`, runs its stages on the
// TexturedMesh, and writes back through the same format's `write(...)`; it never knows the format.
//
// Contract of a ModelFormat:
// - read() returns a LoadedModel whose mesh follows core/mesh.h; faces are in a fixed order that
//   the format's own `source` object maps back to its native structure (OBJ lines, OSG primitive
//   sets, glTF primitives). Every page has its size; a page's pixels are either a file on disk
//   (Page::image_path) or decoded in memory (LoadedModel::page_images[p], for formats that embed
//   images: OSGB, GLB). Decision: embedded images are decoded to memory, never extracted to a
//   scratch folder (no temporary files to clean; the pixels are needed decoded anyway).
// - write() receives the model read, the output mesh (same faces, same order, same positions; new
//   texture coordinates and pages, built by make_output_mesh), and the output page images. It
//   writes the same structure the input had (file names, node structure, everything but texture
//   coordinates and images) through the run's OutputSet, and returns what it wrote.
// - Errors are FormatError (or ObjError/ImageError from the OBJ and image code) naming the file
//   (and, for a file referenced by another, the referencing file).
#pragma once

#include "texdefrag/core/mesh.h"
#include "texdefrag/io/image.h"
#include "texdefrag/io/jpeg_quality.h"
#include "texdefrag/io/output_set.h"

#include <nlohmann/json.hpp>

#include <functional>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

namespace texdefrag {

using json = nlohmann::json;

/// A model file that cannot be read or written; the message starts with the file.
struct FormatError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

/// How an input page was encoded: decides the default output page format (docs/io.md).
struct PageEncoding {
  /// "jpeg", "png", or another lower-case format name; "" when unknown.
  std::string format;
  /// IJG quality (1..100) estimated from the JPEG quantisation tables; empty when not JPEG or when
  /// the tables are not IJG-scaled enough to tell.
  std::optional<int> jpeg_quality;
  /// Bytes of the encoded image (file size, or embedded stream size); 0 when unknown.
  size_t bytes = 0;
  /// Chroma subsampling from the JPEG frame header; empty when not JPEG, grey or unknown.
  std::optional<JpegSubsampling> jpeg_subsampling;
  /// Bits per channel of the stored image (PNG IHDR bit depth, JPEG SOF precision, TIFF
  /// BitsPerSample, 16 for OpenEXR); 0 when unknown. Pages are decoded to 8 bits per channel
  /// (docs/io.md "Images"), so a deeper page's values are rounded: the pipeline warns
  /// (run report "warnings").
  int bits = 0;
};

/// Format-specific state kept between read and write (the scene graph, face -> primitive maps).
/// Opaque to the pipeline; each format downcasts its own.
class ModelSource {
 public:
  virtual ~ModelSource() = default;
};

/// A model as read: the mesh the stages work on plus what the writer needs to write it back.
struct LoadedModel {
  std::string path;    ///< the input file as given
  std::string format;  ///< name() of the format that read it
  TexturedMesh mesh;
  /// One per page. Empty Image: the page is the file mesh.pages[p].image_path; otherwise the
  /// decoded pixels of an embedded image (rows top to bottom, as io/image.h).
  std::vector<Image> page_images;
  /// One per page: how it was encoded.
  std::vector<PageEncoding> page_encodings;
  /// Every file the model was read from or references (model, MTLs, images, ...): never written.
  std::vector<std::string> input_files;
  /// Files the model references that do not exist (e.g. a PagedLOD child), each as
  /// "CHILD: no such file (child 'NAME' of FILE)". The reader does not throw for them: the caller
  /// decides (the pipeline refuses them unless RunOptions::allow_missing_children).
  std::vector<std::string> missing_files;
  /// Positions multiplied by their node transform's stretch for measuring (io/measure_transform.h;
  /// the writer writes the stored positions); 0 when every transform above a mesh is rigid.
  size_t positions_stretched = 0;
  /// Per-format state for write(); may be null for formats that need none.
  std::shared_ptr<ModelSource> source;

  /// Pixels of page p: page_images[p] if not empty, else read from mesh.pages[p].image_path.
  Image page_image(size_t p) const;
};

/// What the output pages look like on disk or in the model.
struct PageWriteOptions {
  ImageFormat format = ImageFormat::Png;
  int jpeg_quality = 95;  ///< [1, 100], used for Jpeg
  JpegSubsampling jpeg_subsampling = JpegSubsampling::S444;  ///< used for Jpeg
  JpegCoding jpeg_coding;  ///< tables and progressive scans, used for Jpeg
  /// True when jpeg_quality is the one estimated from the input pages (match_input_quality).
  bool jpeg_quality_from_input = false;
  /// The quality chosen before any flat-table mapping, as libjpeg's standard tables mean it: the
  /// input's estimate or the configured jpeg_quality. Equals jpeg_quality with standard tables.
  int jpeg_standard_quality = 95;
  /// The validated `output` section of the configuration, for format-specific keys (e.g. the glTF
  /// writer's output.draco); empty object when not given.
  json output_options = json::object();
  /// The pages' encoded streams at exactly these settings, one per page, when something encoded
  /// them already (fit_page_quality keeps its answer's); empty: the writer encodes the pages.
  /// Whoever changes a setting above clears it.
  std::vector<std::vector<uint8_t>> encoded;
};

/// Writes page `p` of `pages` to `path` as `options` say: its stream from options.encoded when
/// present (written atomically by write_file_atomic, io/obj.h), else encoded by write_image.
/// Throws an error starting with `path` when writing fails (ImageError, or ObjError from
/// write_file_atomic), and ImageError when options.encoded does not hold one stream per page.
void write_page(const std::string& path, const std::vector<Image>& pages, size_t p, const PageWriteOptions& options);

/// Page `p`'s encoded stream: options.encoded[p] when present (copied), else encoded now.
std::vector<uint8_t> encode_page(const std::vector<Image>& pages, size_t p, const PageWriteOptions& options);

/// What a writer wrote.
struct WriteResult {
  std::string main_file;            ///< final path of the model file (e.g. OUT/tile.osgb)
  std::vector<std::string> files;   ///< final paths of every file written, main file first
  size_t page_bytes = 0;            ///< bytes of encoded page images (files or embedded streams)
  json report = json::object();     ///< format-specific figures for the run report's write node
};

/// A texture coordinate as written and read back (ModelFormat::texcoord_read_back).
using TexcoordReadBack = std::function<Vec2(const Vec2&)>;

class ModelFormat {
 public:
  virtual ~ModelFormat() = default;
  /// Short lower-case name: "obj", "osgb".
  virtual std::string name() const = 0;
  /// True when this format reads `path` (by extension, or by sniffing the first bytes).
  virtual bool can_read(const std::string& path) const = 0;
  /// Reads a model. Throws FormatError/ObjError/ImageError naming the file on bad input.
  virtual LoadedModel read(const std::string& path) const = 0;
  /// The file name the writer gives the model for output stem `stem` (e.g. "tile" -> "tile.osgb").
  virtual std::string output_name(const std::string& stem) const = 0;
  /// Writes `out_mesh` and `pages` with the structure of `in`.
  /// in: the model as read by this format (in.format == name()).
  /// out_mesh: from make_output_mesh(in.mesh, ...): same faces in the same order, page i of its
  ///   pages is pages[i]; Page::image_path names the file an image-file format writes.
  /// pages: output page images, one per out_mesh.pages entry.
  /// stem: output file stem; page_options: encoding of the pages.
  /// files: the run's one write service (io/output_set.h): every file is claimed with
  ///   files.path_for(name) and appears under its final name only at files.commit(), which the
  ///   caller does.
  virtual WriteResult write(const LoadedModel& in, const TexturedMesh& out_mesh, const std::vector<Image>& pages,
                            const std::string& stem, const PageWriteOptions& page_options,
                            OutputSet& files) const = 0;
  /// An output texture coordinate (make_output_mesh's, normalised, v up) as a reader of the file
  /// write() makes with `page_options` gets it back; the pipeline counts the faces this turns over
  /// (faces_turned_by, run report write.faces_turned_as_written). An empty function: the format
  /// cannot say (the check is skipped and reported so). Default: unchanged (exact formats: the OBJ
  /// writer prints doubles that read back bit-identical).
  virtual TexcoordReadBack texcoord_read_back(const PageWriteOptions& page_options) const;
};

/// Faces of `out` whose UV triangle, with every texture coordinate t replaced by read_back(t),
/// turns the other way or collapses (signed area of the opposite sign, or 0) while it does not
/// with the coordinates as given: faces that a reader of the written file finds turned over,
/// where the output mesh itself has them right (core/distortion.h counts those). Not counted:
/// faces without texture coordinates, and faces of zero UV area in `in` or in `out` as given
/// (a zero-area input face has no orientation to keep; eval counts it apart).
/// in, out: the input and output meshes of one run (the same faces in the same order; a face
///          beyond in's faces counts as having UV area).
/// Cost: one pass over the faces.
size_t faces_turned_by(const TexturedMesh& in, const TexturedMesh& out, const TexcoordReadBack& read_back);

/// x rounded to the nearest float32, as a double: what a format storing float32 reads back.
/// note: written through a volatile float, because GCC 12.2 at -O3 folds the pair of conversions
/// in `Vec2(double(float(t.x())), double(float(t.y())))` away (SLP vectorisation: cvtpd2ps +
/// cvtps2pd dropped), which returned t unchanged.
double stored_as_float32(double x);

/// Every built-in format, in the order they are tried.
const std::vector<const ModelFormat*>& model_formats();

/// The format that reads `path`. Throws FormatError naming the file and the known formats when none
/// does, or when the file does not exist.
const ModelFormat& format_for_input(const std::string& path);

/// The format named `name`, or nullptr.
const ModelFormat* find_model_format(const std::string& name);

/// Lower-case extension of `path` without the dot ("Tile.OSGB" -> "osgb"); "" when none.
std::string lower_extension(const std::string& path);

/// Image format of an encoded image from its first bytes: "jpeg", "png", else the lower-case
/// extension of `name` ("jpg" read as "jpeg"). data/size: the first bytes (8 are enough).
std::string sniff_image_format(const uint8_t* data, size_t size, const std::string& name);

/// The page encoding a file on disk has (format from its first bytes, JPEG quality from its DQT,
/// chroma subsampling from its SOF, bits per channel from its header).
PageEncoding page_encoding_of_file(const std::string& path);

/// Bits per channel an encoded image stores, from its header (PageEncoding::bits): PNG, JPEG,
/// TIFF (both byte orders; the largest BitsPerSample of the first image), OpenEXR (16: half or
/// float); 0 for other formats or a header that cannot be read. `read(offset, n, out)` reads n
/// bytes at offset, false past the end; the header is read, never the pixels.
int image_bits(const std::function<bool(uint64_t, size_t, uint8_t*)>& read);
/// image_bits of an image held in memory.
int image_bits_of_stream(const uint8_t* data, size_t size);

/// The output page encoding for `in` (docs/io.md "Page format").
/// image_format: "png" or "jpeg" force the format; "input" gives JPEG when every textured input page
///   is JPEG, else PNG (PNG in, PNG out; mixed or other formats: PNG, lossless).
/// jpeg_quality: [1, 100], the quality of JPEG pages when match_input_quality is false or no input
///   page has an estimated quality; otherwise the largest estimated quality of the textured input
///   JPEG pages (so no page is written at a lower quality than it was read).
/// jpeg_subsampling: "4:4:4", "4:2:2" or "4:2:0" force the chroma subsampling of JPEG pages;
///   "input" takes the finest subsampling of the textured input JPEG pages (4:4:4 when none is
///   known). Anything else is a FormatError.
/// coding: the JPEG tables and scans. With flat tables the quality chosen (estimate or jpeg_quality,
///   kept in jpeg_standard_quality) becomes the flat tables' quality of no more quantisation noise,
///   flat_quality_for_standard (io/jpeg_quality.h), so the floor means the same with both tables.
PageWriteOptions choose_page_options(const LoadedModel& in, const std::string& image_format, int jpeg_quality,
                                     bool match_input_quality, const std::string& jpeg_subsampling = "4:4:4",
                                     JpegCoding coding = {});

/// output.jpeg_quality_fit "input_bytes" (docs/io.md "Page format"): when `po` writes JPEG pages
/// at the quality estimated from the input (po.jpeg_quality_from_input), raises po.jpeg_quality to
/// the highest quality in [that estimate, max_quality] at which `pages` encode to at most the
/// input's page bytes (the sum of in.page_encodings' bytes, as the run report's input_page_bytes),
/// by fit_jpeg_quality (io/jpeg_quality.h). The quality is never lowered below the estimate.
/// Nothing is searched (probes 0, po unchanged) for PNG pages, a quality not from the input,
/// max_quality at or below the estimate (nothing to raise: the six OBJ development tiles' quality
/// 100), no page, or a textured input page whose bytes are unknown. With flat tables (po.jpeg_coding)
/// max_quality is a standard quality too and is mapped by flat_quality_for_standard.
JpegQualityFit fit_page_quality(const LoadedModel& in, const std::vector<Image>& pages, PageWriteOptions& po,
                                int max_quality);

}  // namespace texdefrag
