// The OBJ format behind ModelFormat (see texdefrag/io/obj_format.h).
#include "texdefrag/io/obj_format.h"

#include "texdefrag/io/obj.h"
#include "texdefrag/util/parallel.h"

#include <exception>
#include <filesystem>
#include <thread>

namespace fs = std::filesystem;

namespace texdefrag {

namespace {

/// Encodes and writes the pages on the framework's threads (each page's file depends on its pixels
/// only) and writes the OBJ and MTL. With more than one thread the OBJ and MTL are written on a
/// thread of their own while the pages are encoded: a tile's one page is one thread's work (its
/// progressive JPEG: 0.13-0.2 s on the development tiles), which left the other core idle. Each
/// file's bytes depend on its own content only, so they do not depend on the thread count; a page's
/// error is thrown before the OBJ's, as when they were written in turn.
void write_pages_and_obj(const TexturedMesh& out_mesh, const std::vector<Image>& pages,
                         const PageWriteOptions& page_options, const std::vector<std::string>& image_paths,
                         const std::string& obj_path, const ObjWriteOptions& wo) {
  const auto write_pages = [&] {
    parallel_for(pages.size(), [&](size_t p) { write_page(image_paths[p], pages, p, page_options); });
  };
  if (thread_count() <= 1 || pages.empty()) {
    write_pages();
    write_obj(out_mesh, obj_path, wo);
    return;
  }
  std::exception_ptr obj_error;
  std::thread obj_thread([&] {
    try {
      write_obj(out_mesh, obj_path, wo);
    } catch (...) {
      obj_error = std::current_exception();
    }
  });
  try {
    write_pages();
  } catch (...) {
    obj_thread.join();
    throw;
  }
  obj_thread.join();
  if (obj_error) std::rethrow_exception(obj_error);
}

}  // namespace

bool ObjFormat::can_read(const std::string& path) const { return lower_extension(path) == "obj"; }

LoadedModel ObjFormat::read(const std::string& path) const {
  LoadedModel m;
  m.path = path;
  m.format = name();
  m.mesh = read_obj(path);
  m.page_images.resize(m.mesh.pages.size());
  m.input_files = m.mesh.source_files;  // the OBJ, every MTL, every page
  for (const Page& p : m.mesh.pages) m.page_encodings.push_back(page_encoding_of_file(p.image_path));
  return m;
}

WriteResult ObjFormat::write(const LoadedModel& in, const TexturedMesh& out_mesh, const std::vector<Image>& pages,
                             const std::string& stem, const PageWriteOptions& page_options,
                             OutputSet& files) const {
  if (pages.size() != out_mesh.pages.size())
    throw FormatError(files.final_path(output_name(stem)) + ": " + std::to_string(pages.size()) + " page images for " +
                      std::to_string(out_mesh.pages.size()) + " pages");
  WriteResult r;
  r.main_file = files.final_path(output_name(stem));
  r.files.push_back(r.main_file);
  std::vector<std::string> image_files, image_paths;
  for (size_t p = 0; p < pages.size(); ++p) {
    const std::string name = fs::path(out_mesh.pages[p].image_path).filename().string();
    image_paths.push_back(files.path_for(name));
    image_files.push_back(files.final_path(name));
  }
  ObjWriteOptions wo;
  wo.protected_paths = in.input_files;
  wo.mtl_name = stem + ".mtl";
  const std::string obj_path = files.path_for(output_name(stem));
  if (!out_mesh.materials.empty()) {
    const std::string mtl_path = files.path_for(wo.mtl_name);
    if (fs::path(mtl_path).parent_path() != fs::path(obj_path).parent_path())
      throw FormatError(mtl_path + ": the MTL must be written beside " + obj_path);
    r.files.push_back(files.final_path(wo.mtl_name));
  }
  write_pages_and_obj(out_mesh, pages, page_options, image_paths, obj_path, wo);
  for (const std::string& path : image_paths) r.page_bytes += static_cast<size_t>(fs::file_size(path));
  r.files.insert(r.files.end(), image_files.begin(), image_files.end());
  return r;
}

}  // namespace texdefrag
