#include "texdefrag/testing/fixtures.h"

#include "texdefrag/io/image.h"
#include "texdefrag/util/paths.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <mutex>
#include <string>
#include <unistd.h>

namespace fs = std::filesystem;

namespace texdefrag::testing {

std::string shared_data(const std::string& relative) {
  const fs::path p = fs::path(shared_data_dir()) / relative;
  std::error_code ec;
  return fs::exists(p, ec) ? fs::absolute(p).string() : std::string();
}

std::vector<std::string> real_models(size_t max_faces) {
  // note: sizes from ../shared/data/README.md, smallest first; filter without reading the files.
  static const std::pair<const char*, size_t> kModels[] = {
      {"contextcapture/rural_t007_078_L15/t078_L15.obj", 2573},
      {"contextcapture/rural_t007_078_L17/t078_L17.obj", 8974},
      {"ycb_banana/textured_simple_reoriented.obj", 15700},
      {"contextcapture/prod5_t017_L18/t017_L18.obj", 22695},
      {"contextcapture/prod5_t015_L18/t015_L18.obj", 23334},
      {"contextcapture/prod5_t016_L18/t016_L18.obj", 23962},
      {"contextcapture/prod5_t016_L19/t016_L19.obj", 46382},
  };
  std::vector<std::string> out;
  for (const auto& m : kModels) {
    if (max_faces && m.second > max_faces) continue;
    const std::string p = shared_data(m.first);
    if (!p.empty()) out.push_back(p);
  }
  return out;
}

namespace {

/// Removes the process's temporary folder at the end of a test program whose tests all passed; a
/// failing test prints where its files are kept (after its failure message), and a failing program
/// keeps the whole folder and says so.
class TempFolderKeeper : public ::testing::EmptyTestEventListener {
 public:
  explicit TempFolderKeeper(fs::path root) : root_(std::move(root)) {}
  const fs::path& root() const { return root_; }
  /// Records a folder made for the running test.
  void made(const fs::path& p) {
    std::lock_guard<std::mutex> lock(mutex_);
    current_.push_back(p);
  }
  void OnTestStart(const ::testing::TestInfo&) override {
    std::lock_guard<std::mutex> lock(mutex_);
    current_.clear();
    told_ = false;
  }
  void OnTestPartResult(const ::testing::TestPartResult& r) override {
    std::lock_guard<std::mutex> lock(mutex_);
    if (!r.failed() || told_ || current_.empty()) return;
    told_ = true;
    for (const fs::path& p : current_) std::printf("[  FILES   ] this test's files are kept in %s\n", p.string().c_str());
    std::fflush(stdout);
  }
  void OnTestProgramEnd(const ::testing::UnitTest& unit) override {
    if (unit.Passed()) {
      std::error_code ec;
      fs::remove_all(root_, ec);
      if (ec) std::printf("[  FILES   ] could not remove %s: %s\n", root_.string().c_str(), ec.message().c_str());
    } else {
      std::printf("[  FILES   ] tests failed: their files are kept in %s (removed when every test passes)\n",
                  root_.string().c_str());
    }
    std::fflush(stdout);
  }

 private:
  fs::path root_;
  std::mutex mutex_;
  std::vector<fs::path> current_;
  bool told_ = false;
};

}  // namespace

std::string temp_dir(const std::string& suffix) {
  const ::testing::TestInfo* info = ::testing::UnitTest::GetInstance()->current_test_info();
  std::string name = info ? std::string(info->test_suite_name()) + "." + info->name() : "test";
  for (char& c : name)
    if (c == '/') c = '_';
  // note: one folder per test process (texdefrag-tests-<pid>): several builds on one machine run
  // the same tests at once (engineers' worktrees, CI), and a shared folder per test name let one
  // run remove another's files mid-test (Pipeline.EveryConfigRunsEndToEnd lost a report that way).
  // The first call registers the listener that removes it when every test passed (gtest owns and
  // deletes listeners).
  static TempFolderKeeper* const keeper = [] {
    auto* k = new TempFolderKeeper(fs::temp_directory_path() / ("texdefrag-tests-" + std::to_string(::getpid())));
    ::testing::UnitTest::GetInstance()->listeners().Append(k);
    return k;
  }();
  const fs::path p = keeper->root() / (name + suffix);
  fs::remove_all(p);
  fs::create_directories(p);
  keeper->made(p);
  return p.string();
}

void write_test_image(const std::string& path, int width, int height, bool gradient) {
  Image img;
  img.width = width;
  img.height = height;
  img.channels = 3;
  img.pixels.resize(static_cast<size_t>(width) * static_cast<size_t>(height) * 3);
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) {
      uint8_t* p = img.at(x, y);
      if (gradient) {
        p[0] = static_cast<uint8_t>((x * 255) / std::max(1, width - 1));
        p[1] = static_cast<uint8_t>((y * 255) / std::max(1, height - 1));
        p[2] = static_cast<uint8_t>(((x / 4 + y / 4) % 2) * 200);
      } else {
        p[0] = 200; p[1] = 120; p[2] = 40;
      }
    }
  write_image(path, img, ImageFormat::Png);
}

void write_surface_texture(const TexturedMesh& mesh, int page, const std::string& path, double period_3d,
                           int padding) {
  const Page& pg = mesh.pages[static_cast<size_t>(page)];
  Image img;
  img.width = pg.width;
  img.height = pg.height;
  img.channels = 3;
  img.pixels.assign(static_cast<size_t>(img.width) * static_cast<size_t>(img.height) * 3, 0);
  std::vector<uint8_t> interior(static_cast<size_t>(img.width) * static_cast<size_t>(img.height), 0);
  const double w = 2 * M_PI / period_3d;
  auto colour = [&](const Vec3& p, uint8_t* out) {
    out[0] = static_cast<uint8_t>(128 + 100 * std::sin(w * p.x()) * std::cos(0.7 * w * p.y()));
    out[1] = static_cast<uint8_t>(128 + 100 * std::sin(0.8 * w * (p.x() + p.z())));
    out[2] = static_cast<uint8_t>(128 + 100 * std::cos(0.6 * w * p.y() - 0.9 * w * p.z()));
  };
  // Pass 0 paints the padding (extrapolated), pass 1 the interiors, which win.
  for (int pass = 0; pass < 2; ++pass)
    for (size_t f = 0; f < mesh.faces.size(); ++f) {
      if (mesh.faces[f].page != page) continue;
      const Vec2 t[3] = {mesh.corner_texel(f, 0), mesh.corner_texel(f, 1), mesh.corner_texel(f, 2)};
      const double det = (t[1] - t[0]).x() * (t[2] - t[0]).y() - (t[1] - t[0]).y() * (t[2] - t[0]).x();
      if (det == 0) continue;
      const double m = pass == 0 ? padding : 0.0;
      const int x0 = std::max(0, static_cast<int>(std::floor(std::min({t[0].x(), t[1].x(), t[2].x()}) - m)));
      const int x1 = std::min(img.width - 1, static_cast<int>(std::ceil(std::max({t[0].x(), t[1].x(), t[2].x()}) + m)));
      const int y0 = std::max(0, static_cast<int>(std::floor(std::min({t[0].y(), t[1].y(), t[2].y()}) - m)));
      const int y1 = std::min(img.height - 1, static_cast<int>(std::ceil(std::max({t[0].y(), t[1].y(), t[2].y()}) + m)));
      for (int ty = y0; ty <= y1; ++ty)
        for (int tx = x0; tx <= x1; ++tx) {
          const Vec2 c(tx + 0.5, ty + 0.5);  // texel centre, y up
          const double b1 = ((c - t[0]).x() * (t[2] - t[0]).y() - (c - t[0]).y() * (t[2] - t[0]).x()) / det;
          const double b2 = ((t[1] - t[0]).x() * (c - t[0]).y() - (t[1] - t[0]).y() * (c - t[0]).x()) / det;
          const double b0 = 1 - b1 - b2;
          const int row = img.height - 1 - ty;
          const size_t idx = static_cast<size_t>(row) * static_cast<size_t>(img.width) + static_cast<size_t>(tx);
          if (pass == 1) {
            if (b0 < 0 || b1 < 0 || b2 < 0) continue;
            interior[idx] = 1;
          } else if (interior[idx]) {
            continue;
          }
          const Vec3 p = b0 * mesh.corner_position(f, 0) + b1 * mesh.corner_position(f, 1) + b2 * mesh.corner_position(f, 2);
          colour(p, img.at(tx, row));
        }
    }
  write_image(path, img, ImageFormat::Png);
}

namespace {
void add_page(TexturedMesh& m, int page_size, const std::string& image_path) {
  Material mat;
  mat.name = "page0";
  mat.map_kd = fs::path(image_path).filename().string();
  m.materials.push_back(mat);
  Page p;
  p.material = "page0";
  p.image_path = image_path;
  p.width = page_size;
  p.height = page_size;
  m.pages.push_back(p);
}
}  // namespace

TexturedMesh grid_mesh(int nx, int ny, int page_size, const std::string& image_path, double margin) {
  TexturedMesh m;
  add_page(m, page_size, image_path);
  for (int j = 0; j <= ny; ++j)
    for (int i = 0; i <= nx; ++i) {
      m.positions.emplace_back(i, j, 0);
      m.texcoords.emplace_back(margin + (1 - 2 * margin) * i / nx, margin + (1 - 2 * margin) * j / ny);
    }
  auto id = [&](int i, int j) { return j * (nx + 1) + i; };
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i) {
      for (const auto& tri : {std::array<int, 3>{id(i, j), id(i + 1, j), id(i + 1, j + 1)},
                              std::array<int, 3>{id(i, j), id(i + 1, j + 1), id(i, j + 1)}}) {
        Face f;
        f.v = tri;
        f.vt = tri;
        f.material = 0;
        f.page = 0;
        f.source_line = static_cast<int>(m.faces.size()) + 1;
        m.faces.push_back(f);
      }
    }
  return m;
}

TexturedMesh fragmented_grid_mesh(int nx, int ny, int page_size, const std::string& image_path) {
  TexturedMesh m;
  add_page(m, page_size, image_path);
  const int n = 2 * nx * ny;
  const int cols = static_cast<int>(std::ceil(std::sqrt(static_cast<double>(n))));
  const double cell = 1.0 / cols;
  int t = 0;
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i)
      for (int h = 0; h < 2; ++h, ++t) {
        const Vec3 a(i, j, 0), b(i + 1, j, 0), c(i + 1, j + 1, 0), d(i, j + 1, 0);
        const std::array<Vec3, 3> tri = h == 0 ? std::array<Vec3, 3>{a, b, c} : std::array<Vec3, 3>{a, c, d};
        const double u0 = (t % cols) * cell + 0.1 * cell, v0 = (t / cols) * cell + 0.1 * cell, s = 0.8 * cell;
        // Each triangle's UVs: same shape as 3D (up to scale), own cell.
        const std::array<Vec2, 3> uv = h == 0
            ? std::array<Vec2, 3>{Vec2(u0, v0), Vec2(u0 + s, v0), Vec2(u0 + s, v0 + s)}
            : std::array<Vec2, 3>{Vec2(u0, v0), Vec2(u0 + s, v0 + s), Vec2(u0, v0 + s)};
        Face f;
        for (int k = 0; k < 3; ++k) {
          f.v[static_cast<size_t>(k)] = static_cast<int>(m.positions.size());
          m.positions.push_back(tri[static_cast<size_t>(k)]);
          f.vt[static_cast<size_t>(k)] = static_cast<int>(m.texcoords.size());
          m.texcoords.push_back(uv[static_cast<size_t>(k)]);
        }
        f.material = 0;
        f.page = 0;
        f.source_line = t + 1;
        m.faces.push_back(f);
      }
  return m;
}

}  // namespace texdefrag::testing
