// numpy arrays <-> OBJ + MTL + PNG pages (arrays.h).
#include "arrays.h"

#include "texdefrag/io/image.h"
#include "texdefrag/io/obj.h"

#include <cmath>
#include <stdexcept>
#include <type_traits>

namespace texdefrag::python {
namespace {

template <class T>
py::array_t<T, py::array::c_style | py::array::forcecast> as_array(const py::object& o, const char* name, int cols) {
  if (std::is_integral<T>::value) {  // indices: no silent rounding of 1.5 to 1
    const py::array raw = py::array::ensure(o);
    if (raw && raw.size() > 0 && raw.dtype().kind() != 'i' && raw.dtype().kind() != 'u')
      throw std::invalid_argument(std::string(name) + ": expected an integer array, got dtype kind '" +
                                  std::string(1, raw.dtype().kind()) + "'");
  }
  auto a = py::array_t<T, py::array::c_style | py::array::forcecast>::ensure(o);
  if (!a) throw std::invalid_argument(std::string(name) + ": not convertible to a numeric array");
  if (cols > 0 && (a.ndim() != 2 || a.shape(1) != cols))
    throw std::invalid_argument(std::string(name) + ": expected shape (n, " + std::to_string(cols) + "), got " +
                                std::to_string(a.ndim()) + " dimensions");
  if (cols == 0 && a.ndim() != 1) throw std::invalid_argument(std::string(name) + ": expected a 1-D array");
  return a;
}

void check_index(long v, size_t n, const char* name, size_t row) {
  if (v < 0 || static_cast<size_t>(v) >= n)
    throw std::invalid_argument(std::string(name) + "[" + std::to_string(row) + "]: index " + std::to_string(v) +
                                " outside [0, " + std::to_string(n) + ")");
}

Image to_image(const py::handle& h, size_t i) {
  auto a = py::array_t<uint8_t, py::array::c_style>::ensure(h);
  const std::string name = "pages[" + std::to_string(i) + "]";
  if (!a || py::array(py::reinterpret_borrow<py::object>(h)).dtype().kind() != 'u' ||
      py::array(py::reinterpret_borrow<py::object>(h)).dtype().itemsize() != 1)
    throw std::invalid_argument(name + ": expected a uint8 array (H, W) or (H, W, C)");
  if (a.ndim() != 2 && a.ndim() != 3) throw std::invalid_argument(name + ": expected shape (H, W) or (H, W, C)");
  Image im;
  im.height = static_cast<int>(a.shape(0));
  im.width = static_cast<int>(a.shape(1));
  im.channels = a.ndim() == 3 ? static_cast<int>(a.shape(2)) : 1;
  if (im.width < 1 || im.height < 1 || im.channels < 1 || im.channels > 4)
    throw std::invalid_argument(name + ": needs at least 1x1 pixels and 1 to 4 channels");
  im.pixels.assign(a.data(), a.data() + a.size());
  return im;
}

}  // namespace

std::string write_model(const std::string& dir, const std::string& stem, const py::object& positions,
                        const py::object& faces, const py::object& uvs, const py::object& face_uvs,
                        const py::object& face_pages, const py::list& pages) {
  const auto P = as_array<double>(positions, "positions", 3);
  const auto F = as_array<long>(faces, "faces", 3);
  const auto T = as_array<double>(uvs, "uvs", 2);
  const auto FT = as_array<long>(face_uvs, "face_uvs", 3);
  const auto FP = as_array<long>(face_pages, "face_pages", 0);
  const size_t nf = static_cast<size_t>(F.shape(0));
  if (static_cast<size_t>(FT.shape(0)) != nf || static_cast<size_t>(FP.shape(0)) != nf)
    throw std::invalid_argument("face_uvs and face_pages need one row per face (" + std::to_string(nf) + ")");
  TexturedMesh m;
  auto p = P.unchecked<2>();
  for (py::ssize_t i = 0; i < P.shape(0); ++i) {
    const Vec3 v(p(i, 0), p(i, 1), p(i, 2));
    if (!v.allFinite()) throw std::invalid_argument("positions[" + std::to_string(i) + "]: not finite");
    m.positions.push_back(v);
  }
  auto t = T.unchecked<2>();
  for (py::ssize_t i = 0; i < T.shape(0); ++i) {
    const Vec2 v(t(i, 0), t(i, 1));
    if (!v.allFinite()) throw std::invalid_argument("uvs[" + std::to_string(i) + "]: not finite");
    m.texcoords.push_back(v);
  }
  for (size_t i = 0; i < pages.size(); ++i) {
    const Image im = to_image(pages[i], i);
    const std::string image = dir + "/" + stem + "_page" + std::to_string(i) + ".png";
    write_image(image, im, ImageFormat::Png);
    m.materials.push_back(Material{"page_" + std::to_string(i), {}, "", ""});
    m.pages.push_back(Page{m.materials.back().name, image, im.width, im.height});
  }
  auto f = F.unchecked<2>();
  auto ft = FT.unchecked<2>();
  auto fp = FP.unchecked<1>();
  bool untextured = false;
  for (size_t i = 0; i < nf; ++i) untextured |= fp(static_cast<py::ssize_t>(i)) < 0;
  const int untextured_material = untextured ? static_cast<int>(m.materials.size()) : kNoIndex;
  if (untextured) m.materials.push_back(Material{"untextured", {}, "", ""});
  for (size_t i = 0; i < nf; ++i) {
    const py::ssize_t r = static_cast<py::ssize_t>(i);
    Face face;
    for (int k = 0; k < 3; ++k) {
      check_index(f(r, k), m.positions.size(), "faces", i);
      face.v[static_cast<size_t>(k)] = static_cast<int>(f(r, k));
    }
    const long page = fp(r);
    if (page >= 0) {
      check_index(page, m.pages.size(), "face_pages", i);
      for (int k = 0; k < 3; ++k) {
        check_index(ft(r, k), m.texcoords.size(), "face_uvs", i);
        face.vt[static_cast<size_t>(k)] = static_cast<int>(ft(r, k));
      }
      face.page = static_cast<int>(page);
      face.material = static_cast<int>(page);
    } else {
      face.material = untextured_material;
    }
    m.faces.push_back(face);
  }
  const std::string obj = dir + "/" + stem + ".obj";
  write_obj(m, obj);
  return obj;
}

py::dict read_model(const std::string& obj_path, bool with_pages) {
  const TexturedMesh m = read_obj(obj_path);
  const py::ssize_t nv = static_cast<py::ssize_t>(m.positions.size()), nt = static_cast<py::ssize_t>(m.texcoords.size()),
                    nf = static_cast<py::ssize_t>(m.faces.size());
  py::array_t<double> P({nv, py::ssize_t(3)}), T({nt, py::ssize_t(2)});
  py::array_t<long> F({nf, py::ssize_t(3)}), FT({nf, py::ssize_t(3)}), FP(nf);
  auto p = P.mutable_unchecked<2>();
  for (py::ssize_t i = 0; i < nv; ++i)
    for (int k = 0; k < 3; ++k) p(i, k) = m.positions[static_cast<size_t>(i)][k];
  auto t = T.mutable_unchecked<2>();
  for (py::ssize_t i = 0; i < nt; ++i)
    for (int k = 0; k < 2; ++k) t(i, k) = m.texcoords[static_cast<size_t>(i)][k];
  auto f = F.mutable_unchecked<2>();
  auto ft = FT.mutable_unchecked<2>();
  auto fp = FP.mutable_unchecked<1>();
  for (py::ssize_t i = 0; i < nf; ++i) {
    const Face& face = m.faces[static_cast<size_t>(i)];
    for (int k = 0; k < 3; ++k) {
      f(i, k) = face.v[static_cast<size_t>(k)];
      ft(i, k) = face.vt[static_cast<size_t>(k)];
    }
    fp(i) = face.page;
  }
  py::dict d;
  d["positions"] = P;
  d["faces"] = F;
  d["uvs"] = T;
  d["face_uvs"] = FT;
  d["face_pages"] = FP;
  py::list pages;
  if (with_pages)
    for (const Page& pg : m.pages) {
      const Image im = read_image(pg.image_path);
      py::array_t<uint8_t> a({py::ssize_t(im.height), py::ssize_t(im.width), py::ssize_t(im.channels)});
      std::copy(im.pixels.begin(), im.pixels.end(), a.mutable_data());
      pages.append(a);
    }
  d["pages"] = pages;
  return d;
}

}  // namespace texdefrag::python
