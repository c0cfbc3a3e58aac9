// Structural check and comparison of 3D Tiles tilesets (see texdefrag/io/tiles3d.h).
#include "texdefrag/io/tiles3d.h"

#include "gltf_internal.h"

#include <algorithm>
#include <Eigen/Dense>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>

namespace fs = std::filesystem;

namespace texdefrag {

using gltf_detail::ojson;

namespace {

using Mat4 = Eigen::Matrix4d;

/// True when `a` is an array of `n` numbers (read with operator[] only then: a const JSON read out
/// of range is undefined behaviour).
bool numbers(const ojson& a, size_t n) {
  if (!a.is_array() || a.size() != n) return false;
  for (const ojson& v : a)
    if (!v.is_number()) return false;
  return true;
}

/// `a` when it is an array of `n` numbers, else throws naming `what`.
const ojson& checked_numbers(const ojson& a, size_t n, const char* what) {
  if (!numbers(a, n)) throw TilesetError(std::string(what) + " is not an array of " + std::to_string(n) + " numbers");
  return a;
}

Mat4 mat_of(const ojson& a) {
  Mat4 m = Mat4::Identity();
  if (numbers(a, 16))
    for (int i = 0; i < 16; ++i) m(i % 4, i / 4) = a[static_cast<size_t>(i)].get<double>();  // column-major
  return m;
}

/// A glTF node's local matrix (matrix, or translation * rotation * scale).
Mat4 node_matrix(const ojson& n) {
  if (n.contains("matrix")) return mat_of(n["matrix"]);
  Mat4 m = Mat4::Identity();
  if (n.contains("scale")) {
    const ojson& s = checked_numbers(n["scale"], 3, "a node's scale");
    m = Eigen::Vector4d(s[0].get<double>(), s[1].get<double>(), s[2].get<double>(), 1).asDiagonal();
  }
  if (n.contains("rotation")) {
    const auto& r = checked_numbers(n["rotation"], 4, "a node's rotation");
    const Eigen::Quaterniond q(r[3].get<double>(), r[0].get<double>(), r[1].get<double>(), r[2].get<double>());
    Mat4 R = Mat4::Identity();
    R.topLeftCorner<3, 3>() = q.normalized().toRotationMatrix();
    m = R * m;
  }
  if (n.contains("translation")) {
    Mat4 T = Mat4::Identity();
    const ojson& t = checked_numbers(n["translation"], 3, "a node's translation");
    for (int i = 0; i < 3; ++i) T(i, 3) = t[static_cast<size_t>(i)].get<double>();
    m = T * m;
  }
  return m;
}

/// Positions of a content in its tile's frame (before the tile transform).
std::vector<Eigen::Vector3d> content_points(const std::string& path, const ojson& tileset_asset) {
  std::vector<uint8_t> bytes;
  {
    std::ifstream in(path, std::ios::binary);
    bytes.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  }
  Eigen::Vector3d rtc = Eigen::Vector3d::Zero();
  GltfInput gi{path, {}, ""};
  if (fs::path(path).extension() == ".b3dm") {
    const B3dm b = parse_b3dm(bytes, path);
    if (!b.feature_table_json.empty()) {
      const ojson ft = ojson::parse(b.feature_table_json);
      if (ft.contains("RTC_CENTER")) {
        const ojson& c = checked_numbers(ft["RTC_CENTER"], 3, "the feature table's RTC_CENTER");
        for (int i = 0; i < 3; ++i) rtc[i] = c[static_cast<size_t>(i)].get<double>();
      }
    }
    gi.bytes = b.glb;
    gi.base_dir = fs::path(path).parent_path().string();
  }
  GltfReadOptions ro;
  ro.read_page_sizes = false;
  const GltfModel g = read_gltf(std::vector<GltfInput>{gi}, ro);
  const gltf_detail::Document& d = (*g.documents)[0];
  if (d.json.contains("extensions") && d.json["extensions"].contains("CESIUM_RTC")) {
    const ojson& c = checked_numbers(d.json["extensions"]["CESIUM_RTC"].value("center", ojson()), 3, "CESIUM_RTC's center");
    for (int i = 0; i < 3; ++i) rtc[i] += c[static_cast<size_t>(i)].get<double>();
  }
  // World matrices of every node holding a mesh, scene by scene.
  std::vector<std::vector<Mat4>> mesh_worlds(d.json.contains("meshes") ? d.json["meshes"].size() : 0);
  const ojson nodes = d.json.value("nodes", ojson::array());
  // note: at() (not operator[]) and a depth limit: node indices and children come from the file.
  std::function<void(size_t, const Mat4&, size_t)> visit = [&](size_t n, const Mat4& parent, size_t depth) {
    if (depth > nodes.size()) throw TilesetError(path + ": the node hierarchy has a cycle");
    const Mat4 w = parent * node_matrix(nodes.at(n));
    if (nodes[n].contains("mesh")) mesh_worlds.at(nodes[n]["mesh"].get<size_t>()).push_back(w);
    for (const auto& c : nodes[n].value("children", ojson::array())) visit(c.get<size_t>(), w, depth + 1);
  };
  if (d.json.contains("scenes")) {
    const size_t s = d.json.value("scene", 0);
    for (const auto& n : d.json["scenes"].at(s).value("nodes", ojson::array())) visit(n.get<size_t>(), Mat4::Identity(), 0);
  }
  // glTF is y-up; 3D Tiles z-up (asset.gltfUpAxis may say otherwise in 1.0).
  Mat4 up = Mat4::Identity();
  const std::string axis = tileset_asset.value("gltfUpAxis", std::string("Y"));
  if (axis == "Y") up << 1, 0, 0, 0, 0, 0, -1, 0, 0, 1, 0, 0, 0, 0, 0, 1;
  else if (axis == "X") up << 0, 0, 1, 0, 0, 1, 0, 0, -1, 0, 0, 0, 0, 0, 0, 1;
  std::vector<Eigen::Vector3d> pts;
  for (size_t f = 0; f < g.mesh.faces.size(); ++f)
    for (const Mat4& w : mesh_worlds.at(static_cast<size_t>(g.face_source[f].mesh)))
      for (int k = 0; k < 3; ++k) {
        const Eigen::Vector4d p = up * w * g.mesh.corner_position(f, k).homogeneous();
        pts.push_back(p.head<3>() + rtc);
      }
  return pts;
}

/// Geodetic (lon, lat in radians, height) of an ECEF point on WGS84.
Eigen::Vector3d geodetic(const Eigen::Vector3d& p) {
  const double a = 6378137.0, f = 1 / 298.257223563, b = a * (1 - f), e2 = f * (2 - f), ep2 = (a * a - b * b) / (b * b);
  const double r = std::hypot(p.x(), p.y()), th = std::atan2(p.z() * a, r * b);
  const double lat = std::atan2(p.z() + ep2 * b * std::pow(std::sin(th), 3), r - e2 * a * std::pow(std::cos(th), 3));
  const double n = a / std::sqrt(1 - e2 * std::sin(lat) * std::sin(lat));
  return {std::atan2(p.y(), p.x()), lat, r / std::cos(lat) - n};
}

/// "" when p is inside bounding volume bv (under tile transform T), else why not.
std::string outside(const ojson& bv, const Mat4& T, const Eigen::Vector3d& p, double tol) {
  if (bv.contains("box")) {
    const auto& b = bv["box"];
    if (!numbers(b, 12)) return "box is not an array of 12 numbers";
    const Eigen::Vector3d c = (T * Eigen::Vector4d(b[0].get<double>(), b[1].get<double>(), b[2].get<double>(), 1)).head<3>();
    Eigen::Vector3d r = p - c;
    double size = 0;
    for (int i = 0; i < 3; ++i) {
      const Eigen::Vector3d ax = T.topLeftCorner<3, 3>() * Eigen::Vector3d(b[3 + 3 * i].get<double>(), b[4 + 3 * i].get<double>(), b[5 + 3 * i].get<double>());
      size = std::max(size, ax.norm());
    }
    for (int i = 0; i < 3; ++i) {
      const Eigen::Vector3d ax = T.topLeftCorner<3, 3>() * Eigen::Vector3d(b[3 + 3 * i].get<double>(), b[4 + 3 * i].get<double>(), b[5 + 3 * i].get<double>());
      const double l2 = ax.squaredNorm();
      if (l2 == 0) continue;
      const double t = r.dot(ax) / l2;
      if (std::abs(t) > 1 + tol * size / std::sqrt(l2) + 1e-9) return "outside box axis " + std::to_string(i) + " (" + std::to_string(t) + " half-lengths)";
      r -= t * ax;
    }
    if (r.norm() > tol * size + 1e-9) return "off a flat box by " + std::to_string(r.norm());
    return "";
  }
  if (bv.contains("sphere")) {
    const auto& s = bv["sphere"];
    if (!numbers(s, 4)) return "sphere is not an array of 4 numbers";
    const Eigen::Vector3d c = (T * Eigen::Vector4d(s[0].get<double>(), s[1].get<double>(), s[2].get<double>(), 1)).head<3>();
    const double scale = T.topLeftCorner<3, 3>().colwise().norm().maxCoeff();
    const double rad = s[3].get<double>() * scale;
    return (p - c).norm() <= rad * (1 + tol) + 1e-9 ? "" : "outside sphere";
  }
  if (bv.contains("region")) {
    const auto& g = bv["region"];
    if (!numbers(g, 6)) return "region is not an array of 6 numbers";
    const Eigen::Vector3d q = geodetic(p);
    const double eps = tol * std::max(1e-7, std::abs(g[2].get<double>() - g[0].get<double>()));
    if (q.x() < g[0].get<double>() - eps || q.x() > g[2].get<double>() + eps || q.y() < g[1].get<double>() - eps || q.y() > g[3].get<double>() + eps)
      return "outside region (longitude/latitude)";
    const double h = std::max(1.0, g[5].get<double>() - g[4].get<double>()) * tol;
    if (q.z() < g[4].get<double>() - h - 0.01 || q.z() > g[5].get<double>() + h + 0.01) return "outside region (height)";
    return "";
  }
  return "unsupported bounding volume";
}

ojson load(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw TilesetError(path + ": cannot open");
  return ojson::parse(in);
}

}  // namespace

std::vector<std::string> check_tileset(const std::string& path, double tolerance) {
  std::vector<std::string> problems;
  std::vector<std::string> reading;  // the tileset JSONs being read, entry first (a cycle is an error)
  std::function<void(const std::string&, const Mat4&)> visit_tileset = [&](const std::string& file, const Mat4& base) {
    const std::string key = fs::absolute(file).lexically_normal().string();
    if (std::find(reading.begin(), reading.end(), key) != reading.end())
      throw TilesetError(file + ": external tileset reached again while reading it: a cycle");
    reading.push_back(key);
    const ojson j = load(file);
    const ojson asset = j.value("asset", ojson::object());
    std::function<void(const ojson&, const Mat4&, const std::string&)> tile = [&](const ojson& t, const Mat4& parent, const std::string& where) {
      if (!t.is_object()) {
        problems.push_back(file + " " + where + ": the tile is not a JSON object");
        return;
      }
      const Mat4 T = parent * (t.contains("transform") ? mat_of(t["transform"]) : Mat4::Identity());
      std::vector<ojson> cs;
      if (t.contains("content")) cs.push_back(t["content"]);
      for (const auto& c : t.value("contents", ojson::array())) cs.push_back(c);
      for (const ojson& c : cs) {
        const std::string uri = c.value("uri", c.value("url", std::string()));
        const std::string p = (fs::path(file).parent_path() / gltf_detail::url_decode(uri)).lexically_normal().string();
        if (!fs::is_regular_file(p)) {
          problems.push_back(file + " " + where + ": content '" + uri + "' does not exist");
          continue;
        }
        if (fs::path(p).extension() == ".json") {
          visit_tileset(p, T);
          continue;
        }
        const std::string ext = fs::path(p).extension().string();
        if (ext != ".glb" && ext != ".gltf" && ext != ".b3dm") continue;
        std::vector<Eigen::Vector3d> pts;
        try {
          pts = content_points(p, asset);
        } catch (const std::exception& e) {
          problems.push_back(file + " " + where + ": " + e.what());
          continue;
        }
        size_t bad = 0, bad_content = 0;
        std::string why;
        for (const auto& q : pts) {
          const Eigen::Vector3d w = (T * q.homogeneous()).head<3>();
          const std::string o = outside(t.value("boundingVolume", ojson()), T, w, tolerance);
          if (!o.empty()) {
            ++bad;
            if (why.empty()) why = o;
          }
          if (c.contains("boundingVolume") && !outside(c["boundingVolume"], T, w, tolerance).empty()) ++bad_content;
        }
        if (bad) problems.push_back(file + " " + where + ": " + std::to_string(bad) + " of " + std::to_string(pts.size()) + " positions of " + uri + " lie outside the tile's bounding volume (" + why + ")");
        if (bad_content) problems.push_back(file + " " + where + ": " + std::to_string(bad_content) + " positions of " + uri + " lie outside the content's bounding volume");
      }
      const ojson children = t.value("children", ojson::array());
      for (size_t i = 0; i < children.size(); ++i) tile(children[i], T, where + "/" + std::to_string(i));
    };
    // note: operator[] of a const JSON object on a missing key reads freed memory (found by
    // fuzz_tiles3d on a tileset without "root"): every lookup here checks first.
    if (!j.is_object() || !j.contains("root")) throw TilesetError(file + ": not a tileset (no \"root\" tile)");
    tile(j["root"], base, "root");
    reading.pop_back();
  };
  try {
    visit_tileset(path, Mat4::Identity());
  } catch (const std::exception& e) {
    problems.push_back(e.what());
  }
  return problems;
}

std::vector<std::string> compare_tilesets(const std::string& a, const std::string& b) {
  std::vector<std::string> diffs;
  std::function<void(const std::string&, const std::string&)> cmp_file = [&](const std::string& fa, const std::string& fb) {
    const ojson ja = load(fa), jb = load(fb);
    if (ja.value("geometricError", ojson()) != jb.value("geometricError", ojson())) diffs.push_back(fb + ": top-level geometricError differs");
    if (ja.value("asset", ojson()).value("version", ojson()) != jb.value("asset", ojson()).value("version", ojson()))
      diffs.push_back(fb + ": asset.version differs");
    std::function<void(const ojson&, const ojson&, const std::string&)> tile = [&](const ojson& ta, const ojson& tb, const std::string& where) {
      for (const char* k : {"boundingVolume", "transform", "geometricError", "refine", "extras", "viewerRequestVolume"})
        if (ta.value(k, ojson()) != tb.value(k, ojson())) diffs.push_back(fb + " " + where + ": " + k + " differs");
      std::vector<std::string> ua, ub;
      for (const ojson* t : {&ta, &tb}) {
        std::vector<std::string>& u = t == &ta ? ua : ub;
        if (t->contains("content")) u.push_back((*t)["content"].value("uri", std::string()));
        for (const auto& c : t->value("contents", ojson::array())) u.push_back(c.value("uri", std::string()));
      }
      if (ua != ub) diffs.push_back(fb + " " + where + ": content URIs differ");
      for (size_t i = 0; i < ua.size() && i < ub.size(); ++i)
        if (fs::path(ua[i]).extension() == ".json")
          cmp_file((fs::path(fa).parent_path() / ua[i]).string(), (fs::path(fb).parent_path() / ub[i]).string());
      const ojson ca = ta.value("children", ojson::array()), cb = tb.value("children", ojson::array());
      if (ca.size() != cb.size()) {
        diffs.push_back(fb + " " + where + ": " + std::to_string(cb.size()) + " children, input has " + std::to_string(ca.size()));
        return;
      }
      for (size_t i = 0; i < ca.size(); ++i) tile(ca[i], cb[i], where + "/" + std::to_string(i));
    };
    tile(ja.value("root", ojson()), jb.value("root", ojson()), "root");
  };
  try {
    cmp_file(a, b);
  } catch (const std::exception& e) {
    diffs.push_back(e.what());
  }
  return diffs;
}

}  // namespace texdefrag
