// glTF 2.0 / GLB behind the ModelFormat interface (io/model_format.h), on top of io/gltf.h.
// Output options (output.draco ...) are parsed by the pipeline's writer options; see docs/io.md.
#pragma once

#include "texdefrag/io/gltf.h"
#include "texdefrag/io/model_format.h"

namespace texdefrag {

/// The format's state between read and write: the glTF model(s) read.
struct GltfSource : ModelSource {
  GltfModel model;
  std::string root;  ///< folder the output layout mirrors (the input file's folder, or a tileset's)
};

class GltfFormat : public ModelFormat {
 public:
  std::string name() const override { return "gltf"; }
  /// By extension (.glb, .gltf) or the GLB magic.
  bool can_read(const std::string& path) const override;
  LoadedModel read(const std::string& path) const override;
  /// Several documents read as one model (files sharing one atlas). root: the folder whose layout
  /// the output mirrors; every input file and every file they reference must lie under it.
  LoadedModel read_group(const std::vector<GltfInput>& inputs, const std::string& root) const;
  std::string output_name(const std::string& stem) const override { return stem + ".glb"; }
  /// A single input keeps its extension under the name `stem`; a group keeps every file name
  /// (relative to its root). External page images are written where the input's were, named after
  /// them; embedded ones are embedded again. Draco output follows `draco` (default none).
  WriteResult write(const LoadedModel& in, const TexturedMesh& out_mesh, const std::vector<Image>& pages,
                    const std::string& stem, const PageWriteOptions& page_options, OutputSet& files) const override;
  /// Builds the documents without writing them (the 3D Tiles writer wraps GLBs into b3dm).
  /// names: output name (relative to the output folder) of each input document.
  GltfOutput build(const LoadedModel& in, const TexturedMesh& out_mesh, const std::vector<Image>& pages,
                   const std::vector<std::string>& names, const PageWriteOptions& page_options) const;

  /// Float32 coordinates, v stored as 1 - v (glTF's origin is top left); empty with Draco output
  /// `quantized` (the quantisation grid is the encoder's).
  TexcoordReadBack texcoord_read_back(const PageWriteOptions& page_options) const override;
  /// write_options with the configuration's `output.draco*` keys (page_options.output_options)
  /// where given: what build() writes with.
  GltfWriteOptions write_options_for(const PageWriteOptions& page_options) const;

  GltfWriteOptions write_options;  ///< Draco output; set from the configuration by the caller
};

/// Encodes an image as JPEG or PNG bytes (through io/image.h and a temporary file).
std::vector<uint8_t> encode_image(const Image& image, const PageWriteOptions& options);

}  // namespace texdefrag
