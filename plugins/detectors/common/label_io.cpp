#include "common/label_io.h"

#include "texdefrag/io/obj.h"

#include <cerrno>
#include <climits>
#include <cstdlib>
#include <fstream>
#include <sstream>

namespace texdefrag::detectors {
namespace {

bool is_json_path(const std::string& path) {
  return path.size() >= 5 && path.compare(path.size() - 5, 5, ".json") == 0;
}

/// Parses one whole-line integer (surrounding blanks allowed). False when it is not exactly one int.
bool parse_int(const std::string& s, int& out) {
  size_t b = s.find_first_not_of(" \t\r");
  size_t e = s.find_last_not_of(" \t\r");
  if (b == std::string::npos) return false;
  const std::string t = s.substr(b, e - b + 1);
  errno = 0;
  char* end = nullptr;
  const long v = std::strtol(t.c_str(), &end, 10);
  if (end != t.c_str() + t.size() || errno == ERANGE || v < INT_MIN || v > INT_MAX) return false;
  out = static_cast<int>(v);
  return true;
}

}  // namespace

std::vector<int> read_face_labels(const std::string& who, const std::string& path, size_t num_faces,
                                  std::vector<size_t>* line_of_label) {
  if (line_of_label) line_of_label->clear();
  std::ifstream in(path, std::ios::binary);
  if (!in) throw StageError(who + ": cannot open label file '" + path + "'");
  std::vector<int> labels;
  if (is_json_path(path)) {
    json j;
    try {
      j = json::parse(in);
    } catch (const json::exception& e) {
      throw StageError(who + ": " + path + ": malformed JSON: " + e.what());
    }
    if (!j.is_object() || !j.contains("face_labels") || !j["face_labels"].is_array())
      throw StageError(who + ": " + path + ": expected an object {\"face_labels\": [integers]}");
    const json& a = j["face_labels"];
    labels.reserve(a.size());
    for (size_t i = 0; i < a.size(); ++i) {
      const json& v = a[i];
      if (!v.is_number_integer() || v.get<long long>() < INT_MIN || v.get<long long>() > INT_MAX)
        throw StageError(who + ": " + path + ": face_labels[" + std::to_string(i) + "] = " + v.dump() +
                         " is not an integer label");
      labels.push_back(v.get<int>());
    }
    if (labels.size() != num_faces)
      throw StageError(who + ": " + path + ": has " + std::to_string(labels.size()) + " labels, the mesh has " +
                       std::to_string(num_faces) + " faces");
    if (line_of_label) line_of_label->assign(labels.size(), 0);
    return labels;
  }
  std::string line;
  size_t lineno = 0;
  labels.reserve(num_faces);
  while (std::getline(in, line)) {
    ++lineno;
    const size_t b = line.find_first_not_of(" \t\r");
    if (b == std::string::npos || line[b] == '#') continue;
    int v = 0;
    if (!parse_int(line, v))
      throw StageError(who + ": " + path + ":" + std::to_string(lineno) + ": expected one integer label, got '" +
                       line.substr(0, 40) + "'");
    if (labels.size() == num_faces)
      throw StageError(who + ": " + path + ":" + std::to_string(lineno) + ": more labels than the mesh's " +
                       std::to_string(num_faces) + " faces");
    labels.push_back(v);
    if (line_of_label) line_of_label->push_back(lineno);
  }
  if (labels.size() != num_faces)
    throw StageError(who + ": " + path + ":" + std::to_string(lineno) + ": has " + std::to_string(labels.size()) +
                     " labels, the mesh has " + std::to_string(num_faces) + " faces");
  return labels;
}

void write_face_labels(const std::string& who, const std::string& path, const Regions& regions) {
  std::ostringstream s;
  if (is_json_path(path)) {
    s << "{\"face_labels\": [";
    for (size_t f = 0; f < regions.face_region.size(); ++f) s << (f ? "," : "") << regions.face_region[f];
    s << "]}\n";
  } else {
    for (int r : regions.face_region) s << r << '\n';
  }
  try {
    write_file_atomic(path, s.str());
  } catch (const std::exception& e) {
    throw StageError(who + ": cannot write label file '" + path + "': " + e.what());
  }
}

}  // namespace texdefrag::detectors
