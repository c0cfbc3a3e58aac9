// The OBJ + MTL format behind the ModelFormat interface: read_obj / write_obj (io/obj.h) with the
// pages as image files beside the OBJ. Bytes written are those write_obj and write_image produce.
#pragma once

#include "texdefrag/io/model_format.h"

namespace texdefrag {

class ObjFormat : public ModelFormat {
 public:
  std::string name() const override { return "obj"; }
  /// By extension: ".obj" in any case.
  bool can_read(const std::string& path) const override;
  /// read_obj(path); pages stay files on disk; input_files = OBJ, MTLs read, page images.
  LoadedModel read(const std::string& path) const override;
  std::string output_name(const std::string& stem) const override { return stem + ".obj"; }
  /// Writes each page as the file named by out_mesh.pages[p].image_path (its file name, in the
  /// output folder), then STEM.obj and STEM.mtl (write_obj).
  WriteResult write(const LoadedModel& in, const TexturedMesh& out_mesh, const std::vector<Image>& pages,
                    const std::string& stem, const PageWriteOptions& page_options,
                    OutputSet& files) const override;
};

}  // namespace texdefrag
