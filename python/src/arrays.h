// numpy arrays <-> a model on disk (OBJ + MTL + PNG pages), through the framework's own reader and
// writers, so array runs take exactly the path of file runs (same checks, same guarantees).
#pragma once

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <string>

namespace texdefrag::python {

namespace py = pybind11;

/// Writes DIR/STEM.obj, STEM.mtl and STEM_page<i>.png from arrays (see docs/python.md):
/// positions (N,3) float, faces (F,3) int, uvs (T,2) float, face_uvs (F,3) int (indices into uvs),
/// face_pages (F,) int (-1 = untextured), pages: list of (H,W) or (H,W,C) uint8 images, C in 1..4.
/// Throws std::invalid_argument naming the argument and row on a bad shape, index or value.
/// Returns the OBJ path.
std::string write_model(const std::string& dir, const std::string& stem, const py::object& positions,
                        const py::object& faces, const py::object& uvs, const py::object& face_uvs,
                        const py::object& face_pages, const py::list& pages);

/// Reads an OBJ (and its pages) into a dict of arrays with the keys above.
py::dict read_model(const std::string& obj_path, bool with_pages);

}  // namespace texdefrag::python
