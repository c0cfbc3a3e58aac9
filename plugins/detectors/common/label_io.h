// Per-face label files: the exchange format between detectors (`write_labels`) and
// detectors.labels (docs/detectors.md, "Label files").
//
// Two formats, chosen by the file name:
// - `*.json`: {"face_labels": [l0, l1, ...]}, one integer per face in input face order.
// - anything else: plain text, one integer per line in input face order. Lines that are empty or
//   start with '#' are skipped.
// Labels are any integers; a negative label means "no region" and is only allowed on untextured
// faces (the reader returns it; detectors.labels checks it).
#pragma once

#include "texdefrag/stage/stage.h"

#include <string>
#include <vector>

namespace texdefrag::detectors {

/// Reads a label file. Throws StageError "WHO: FILE:LINE: cause" (text) or "WHO: FILE: cause" (JSON)
/// when the file is missing, a line is not exactly one integer (or does not fit an int), the JSON
/// is malformed or not {"face_labels": [integers]}, or the count differs from `num_faces`.
/// who: prefix of error messages (the stage name); path: the file; num_faces: faces of the mesh;
/// line_of_label: if not null, receives the 1-based line of each label (0 for JSON files).
std::vector<int> read_face_labels(const std::string& who, const std::string& path, size_t num_faces,
                                  std::vector<size_t>* line_of_label = nullptr);

/// Writes regions as a label file (format by extension as above), atomically. Untextured faces get -1.
/// who: error prefix; path: destination; regions: face_region of every face.
void write_face_labels(const std::string& who, const std::string& path, const Regions& regions);

}  // namespace texdefrag::detectors
