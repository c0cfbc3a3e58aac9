// Test support shared by every test executable: real-data paths that skip cleanly when absent,
// fresh temporary folders, and small hand-built meshes whose answers can be checked by hand.
#pragma once

#include "texdefrag/core/mesh.h"

#include <gtest/gtest.h>

#include <string>
#include <vector>

namespace texdefrag::testing {

/// Absolute path of a file or folder under ../shared/data, or "" when it is absent.
std::string shared_data(const std::string& relative);

/// The real models under ../shared/data (OBJ paths) that are present, smallest first.
/// `max_faces` filters by the documented sizes (0 = all).
std::vector<std::string> real_models(size_t max_faces = 0);

/// A new empty folder named after the running test, under <system temp>/texdefrag-tests-<pid>/ (one
/// folder per test process, so runs of the same tests from several builds never share one).
/// <system temp>/texdefrag-tests-<pid>/ is removed when the test program ends with every test
/// passed; a failing test prints "[  FILES   ] this test's files are kept in <folder>" after its
/// failure message, and a failing program keeps the whole folder and prints where it is.
std::string temp_dir(const std::string& suffix = "");

/// Writes a solid-colour or gradient RGB PNG of the given size (for hand-built meshes' pages).
void write_test_image(const std::string& path, int width, int height, bool gradient = true);

/// Renders page `page` of `mesh` (size from mesh.pages) as a photogrammetry tool would: every
/// texel inside a face's UV triangle, and within `padding` texels around it, gets the colour of a
/// smooth function of the 3D point it maps to (period `period_3d` model units). So the texture is
/// continuous across seams in 3D, and resampled charts can be compared with the input by PSNR.
void write_surface_texture(const TexturedMesh& mesh, int page, const std::string& path, double period_3d = 1.5,
                           int padding = 3);

/// A flat nx-by-ny grid of unit quads (2 triangles each) in the z=0 plane, one page of
/// page_size^2 texels, one chart whose UVs map the grid to [margin, 1-margin]^2.
/// The page's image_path points to `image_path` (not created here).
TexturedMesh grid_mesh(int nx, int ny, int page_size, const std::string& image_path, double margin = 0.1);

/// Like grid_mesh, but every triangle is its own chart (positions and UVs duplicated per face,
/// as photogrammetry exports do), laid out in a row of cells on the page.
TexturedMesh fragmented_grid_mesh(int nx, int ny, int page_size, const std::string& image_path);

}  // namespace texdefrag::testing

/// Skips the test with a message when a ../shared/data path is absent; else binds `var` to it.
#define TEXDEFRAG_REQUIRE_DATA(var, relative)                                              \
  const std::string var = ::texdefrag::testing::shared_data(relative);                      \
  if (var.empty()) GTEST_SKIP() << "shared data absent: ../shared/data/" << (relative)
