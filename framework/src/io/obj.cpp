// Wavefront OBJ + MTL reader and writer (see texdefrag/io/obj.h and docs/io.md).
//
// note: the reader is hand-rolled (whole file in memory, one pass over lines, std::from_chars for
// numbers) because iostream token extraction is ~10x slower on the 4-5 MB exports this tool reads.
// The writer prints doubles with std::to_chars (shortest round-trip form), so every coordinate reads
// back bit-identical.
#include "texdefrag/io/obj.h"

#include "texdefrag/io/image.h"
#include "texdefrag/io/output_set.h"
#include "texdefrag/util/parallel.h"

#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <string_view>
#include <system_error>
#include <unordered_map>
#include <utility>

namespace fs = std::filesystem;

namespace texdefrag {
namespace {

// ---------------------------------------------------------------------------------------------
// Lexing helpers shared by the OBJ and MTL readers.

bool is_space(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\f' || c == '\v'; }

/// A cursor over one line (without its end of line). Tokens are separated by blanks; a token that
/// starts with '#' begins a comment that runs to the end of the line.
struct Line {
  const char* p;
  const char* end;

  void skip_blanks() {
    while (p < end && is_space(*p)) ++p;
  }
  /// True when only blanks or a comment remain.
  bool at_end() {
    skip_blanks();
    return p == end || *p == '#';
  }
  /// Next token, empty at the end of the line or at a comment.
  std::string_view token() {
    if (at_end()) return {};
    const char* b = p;
    while (p < end && !is_space(*p)) ++p;
    return {b, static_cast<size_t>(p - b)};
  }
  /// The rest of the line with leading and trailing blanks removed (comments are NOT stripped:
  /// names and paths may contain '#').
  std::string_view rest() {
    skip_blanks();
    const char* e = end;
    while (e > p && is_space(e[-1])) --e;
    return {p, static_cast<size_t>(e - p)};
  }
};

std::string in_quotes(std::string_view s) {
  std::string out = "'";
  // note: keep messages one line and readable even for binary garbage.
  for (char c : s.substr(0, 60)) out += (static_cast<unsigned char>(c) < 32 || c == 127) ? '?' : c;
  if (s.size() > 60) out += "...";
  out += "'";
  return out;
}

[[noreturn]] void fail(const std::string& file, int line, const std::string& what) {
  throw ObjError(file + ":" + std::to_string(line) + ": " + what);
}

/// Parses a whole token as a finite double; error text in `err` on failure.
bool parse_double(std::string_view tok, double& out, std::string& err) {
  const char* b = tok.data();
  const char* e = b + tok.size();
  // note: std::from_chars rejects a leading '+', which some exporters write.
  if (b < e && *b == '+' && b + 1 < e && *(b + 1) != '-' && *(b + 1) != '+') ++b;
  const auto r = std::from_chars(b, e, out);
  if (r.ec == std::errc::result_out_of_range) {
    err = "number " + in_quotes(tok) + " is outside the range of a double";
    return false;
  }
  if (r.ec != std::errc() || r.ptr != e) {
    err = "expected a number, found " + in_quotes(tok);
    return false;
  }
  if (!std::isfinite(out)) {
    err = "expected a finite number, found " + in_quotes(tok);
    return false;
  }
  return true;
}

bool parse_long(std::string_view tok, long& out) {
  const char* b = tok.data();
  const char* e = b + tok.size();
  if (b < e && *b == '+' && b + 1 < e && *(b + 1) != '-') ++b;
  const auto r = std::from_chars(b, e, out);
  return r.ec == std::errc() && r.ptr == e;
}

/// Whole file into memory. Throws ObjError naming `what_for` context on failure.
std::string slurp(const std::string& path, const std::string& context) {
  std::FILE* f = std::fopen(path.c_str(), "rb");
  if (!f) throw ObjError(context + "cannot open " + path + ": " + std::strerror(errno));
  std::string data;
  // note: sized from the file once and read in place (appending 64 KB pieces to a growing string
  // copied a 129 MB OBJ about twice over); a file that grows while read is still read whole.
  std::error_code size_error;
  const auto size = fs::file_size(path, size_error);
  if (!size_error) data.resize(static_cast<size_t>(size));
  const size_t got = data.empty() ? 0 : std::fread(&data[0], 1, data.size(), f);
  data.resize(got);
  char buf[1 << 16];
  size_t n;
  while ((n = std::fread(buf, 1, sizeof buf, f)) > 0) data.append(buf, n);
  const bool bad = std::ferror(f) != 0;
  std::fclose(f);
  if (bad) throw ObjError(context + "error reading " + path);
  return data;
}

/// Calls fn(line_number, Line) for each line of data; handles LF and CRLF and skips a UTF-8 byte
/// order mark at the start (Windows editors write one).
template <class Fn>
void for_each_line(const std::string& data, Fn&& fn) {
  const char* p = data.data();
  const char* end = p + data.size();
  if (data.compare(0, 3, "\xEF\xBB\xBF") == 0) p += 3;
  int number = 0;
  while (p < end) {
    ++number;
    const char* eol = static_cast<const char*>(std::memchr(p, '\n', static_cast<size_t>(end - p)));
    if (!eol) eol = end;
    const char* le = eol;
    if (le > p && le[-1] == '\r') --le;
    fn(number, Line{p, le});
    p = eol + 1;
  }
}

// ---------------------------------------------------------------------------------------------
// MTL reader.

struct MapOption {
  const char* name;
  int min_args, max_args;
  bool numeric;
};
// note: the option list of the MTL specification (Wavefront, "Texture map statements").
constexpr MapOption kMapOptions[] = {
    {"-blendu", 1, 1, false}, {"-blendv", 1, 1, false}, {"-boost", 1, 1, true},
    {"-mm", 2, 2, true},      {"-o", 1, 3, true},       {"-s", 1, 3, true},
    {"-t", 1, 3, true},       {"-texres", 1, 1, true},  {"-clamp", 1, 1, false},
    {"-bm", 1, 1, true},      {"-imfchan", 1, 1, false}, {"-type", 1, 1, false},
    {"-cc", 1, 1, false},
};

struct MaterialSource {
  std::string file;
  int line = 0;      ///< line of newmtl
  int map_line = 0;  ///< line of map_Kd (0 if none)
};

struct MtlState {
  TexturedMesh& mesh;
  std::unordered_map<std::string, int>& material_index;
  std::vector<MaterialSource>& sources;
};

/// Parses the arguments of a map_Kd statement into options (verbatim) and path.
void parse_map_kd(const std::string& file, int ln, Line line, Material& m) {
  line.skip_blanks();
  const char* opt_begin = line.p;
  const char* opt_end = line.p;
  for (;;) {
    Line probe = line;
    std::string_view tok = probe.token();
    if (tok.empty() || tok[0] != '-' || tok.size() < 2) break;
    // A token like "-1.5" is not an option name; paths never start with a bare option name.
    const MapOption* opt = nullptr;
    for (const MapOption& o : kMapOptions)
      if (tok == o.name) opt = &o;
    if (!opt) fail(file, ln, "unknown map_Kd option " + in_quotes(tok) + " (expected one of -blendu -blendv -boost -mm -o -s -t -texres -clamp -bm -imfchan -type -cc, or a file name)");
    line = probe;
    for (int a = 0; a < opt->max_args; ++a) {
      Line arg_probe = line;
      std::string_view arg = arg_probe.token();
      double d;
      std::string err;
      const bool is_num = !arg.empty() && parse_double(arg, d, err);
      if (a >= opt->min_args && (!opt->numeric || !is_num)) break;  // optional argument absent
      if (arg.empty()) fail(file, ln, "expected " + std::to_string(opt->min_args) + " argument(s) after map_Kd option " + std::string(opt->name));
      if (opt->numeric && !is_num) fail(file, ln, "map_Kd option " + std::string(opt->name) + ": " + err);
      if (std::string_view(opt->name) == "-clamp") {
        if (arg != "on" && arg != "off") fail(file, ln, "map_Kd option -clamp: expected on or off, found " + in_quotes(arg));
        m.clamp = arg == "on";
      }
      line = arg_probe;
    }
    opt_end = line.p;
  }
  m.map_kd_options.assign(opt_begin, static_cast<size_t>(opt_end - opt_begin));
  const std::string_view path = line.rest();
  if (path.empty()) fail(file, ln, "expected a texture file name after map_Kd");
  m.map_kd.assign(path);
}

void read_mtl(const std::string& mtl_path, const std::string& context, MtlState& st) {
  const std::string data = slurp(mtl_path, context);
  int current = kNoIndex;
  for_each_line(data, [&](int ln, Line line) {
    const char* line_begin = line.p;
    if (line.at_end()) return;  // blank or comment
    const std::string_view kw = line.token();
    if (kw == "newmtl") {
      const std::string name(line.rest());
      if (name.empty()) fail(mtl_path, ln, "expected a material name after newmtl");
      const auto it = st.material_index.find(name);
      if (it != st.material_index.end()) {
        const MaterialSource& s = st.sources[static_cast<size_t>(it->second)];
        fail(mtl_path, ln, "material " + in_quotes(name) + " defined twice (first at " + s.file + ":" + std::to_string(s.line) + ")");
      }
      current = static_cast<int>(st.mesh.materials.size());
      st.material_index.emplace(name, current);
      Material m;
      m.name = name;
      st.mesh.materials.push_back(std::move(m));
      st.sources.push_back({mtl_path, ln, 0});
      return;
    }
    if (current == kNoIndex) fail(mtl_path, ln, "expected 'newmtl' before " + in_quotes(kw));
    Material& m = st.mesh.materials[static_cast<size_t>(current)];
    if (kw == "map_Kd" || kw == "map_kd") {
      MaterialSource& src = st.sources[static_cast<size_t>(current)];
      if (src.map_line) fail(mtl_path, ln, "second map_Kd for material " + in_quotes(m.name) + " (first at line " + std::to_string(src.map_line) + ")");
      parse_map_kd(mtl_path, ln, line, m);
      src.map_line = ln;
      return;
    }
    // Every other statement is kept verbatim (without the line end), in order.
    const char* e = line.end;
    while (e > line_begin && is_space(e[-1])) --e;
    m.extra_lines.emplace_back(line_begin, static_cast<size_t>(e - line_begin));
  });
}

/// The texture file of a map_Kd relative to the MTL's folder; accepts Windows separators.
fs::path resolve_texture(const fs::path& mtl_dir, const std::string& map_kd) {
  fs::path p = (mtl_dir / map_kd).lexically_normal();
  std::error_code ec;
  if (!fs::exists(p, ec) && map_kd.find('\\') != std::string::npos) {
    std::string s = map_kd;
    for (char& c : s)
      if (c == '\\') c = '/';
    const fs::path q = (mtl_dir / s).lexically_normal();
    if (fs::exists(q, ec)) return q;
  }
  return p;
}

// ---------------------------------------------------------------------------------------------
// OBJ reader.

struct Corner {
  int v, vt, vn;
};

class ObjReader {
 public:
  ObjReader(const std::string& path, const ObjReadOptions& options) : path_(path), options_(options) {
    const fs::path p(path);
    dir_ = p.has_parent_path() ? p.parent_path() : fs::path(".");
  }

  TexturedMesh read() {
    const std::string data = slurp(path_, "");
    // note: a cheap pre-count of lines bounds every array; it halves the time spent growing them.
    const size_t lines = static_cast<size_t>(std::count(data.begin(), data.end(), '\n')) + 1;
    mesh_.positions.reserve(lines / 3);
    mesh_.texcoords.reserve(lines / 3);
    mesh_.faces.reserve(lines / 3);
    mesh_.source_files.push_back(path_);
    for_each_line(data, [&](int ln, Line line) { statement(ln, line); });
    finish_pages();
    for (const Page& p : mesh_.pages) mesh_.source_files.push_back(p.image_path);
    return std::move(mesh_);
  }

 private:
  void statement(int ln, Line line) {
    if (line.at_end()) return;
    const std::string_view kw = line.token();
    switch (kw.size()) {
      case 1:
        if (kw[0] == 'v') return vec3(ln, line, mesh_.positions, "v");
        if (kw[0] == 'f') return face(ln, line);
        if (kw[0] == 'g' || kw[0] == 'o') return group(line, kw);
        if (kw[0] == 's') return smoothing(ln, line);
        break;
      case 2:
        if (kw == "vt") return texcoord(ln, line);
        if (kw == "vn") return vec3(ln, line, mesh_.normals, "vn");
        break;
      case 6:
        if (kw == "usemtl") return usemtl(ln, line);
        if (kw == "mtllib") return mtllib(ln, line);
        break;
      default:
        break;
    }
    static const char* const kUnsupported[] = {"l", "p", "vp", "curv", "curv2", "surf", "cstype",
                                               "deg", "bmat", "step", "parm", "trim", "hole", "scrv",
                                               "sp", "end", "con", "mg", "bevel", "c_interp",
                                               "d_interp", "lod", "usemap", "maplib", "shadow_obj",
                                               "trace_obj", "ctech", "stech", "call", "csh"};
    for (const char* u : kUnsupported)
      if (kw == u) fail(path_, ln, "unsupported statement " + in_quotes(kw) + " (this reader takes polygon meshes: v, vt, vn, f, g, o, s, usemtl, mtllib)");
    fail(path_, ln, "unknown statement " + in_quotes(kw) + " (expected v, vt, vn, f, g, o, s, usemtl, mtllib or a # comment)");
  }

  double number(int ln, Line& line, const char* what) {
    const std::string_view tok = line.token();
    if (tok.empty()) fail(path_, ln, std::string("expected a number (") + what + ") before the end of the line");
    double d;
    std::string err;
    if (!parse_double(tok, d, err)) fail(path_, ln, err + " (" + what + ")");
    return d;
  }

  void vec3(int ln, Line& line, std::vector<Vec3>& out, const char* kw) {
    const bool is_v = kw[1] == '\0';
    const double x = number(ln, line, is_v ? "x of v" : "x of vn");
    const double y = number(ln, line, is_v ? "y of v" : "y of vn");
    const double z = number(ln, line, is_v ? "z of v" : "z of vn");
    if (!is_v) {
      if (!line.at_end()) fail(path_, ln, "expected 3 numbers after vn, found more");
    } else {
      vertex_extra(ln, line);
    }
    out.emplace_back(x, y, z);
  }

  /// What follows x y z on a `v` line: nothing, w = 1 (the same point), or a colour r g b, which is
  /// kept (TexturedMesh::colors). w != 1, other counts, and a file mixing coloured and plain `v`
  /// lines cannot be carried through, so they are errors rather than silently dropped.
  void vertex_extra(int ln, Line& line) {
    double extra[4];
    int n = 0;
    while (!line.at_end()) {
      if (n == 4) fail(path_, ln, "expected 3 numbers after v (x y z), 4 (x y z w, w = 1) or 6 (x y z r g b), found more");
      extra[n] = number(ln, line, n == 0 ? "4th number of v" : n == 1 ? "5th number of v" : "6th number of v");
      ++n;
    }
    if (n == 2 || n == 4)
      fail(path_, ln, "expected 3 numbers after v (x y z), 4 (x y z w, w = 1) or 6 (x y z r g b), found " + std::to_string(3 + n));
    if (n == 1 && extra[0] != 1.0)
      fail(path_, ln, "v x y z w with w != 1 (a point at infinity or a scaled point) is not supported");
    const bool coloured = n == 3;
    if (mesh_.positions.empty()) {
      first_v_line_ = ln;
      coloured_ = coloured;
    } else if (coloured != coloured_) {
      fail(path_, ln, std::string(coloured ? "a vertex colour (v x y z r g b)" : "no vertex colour") + ", but the first v line (line " +
                          std::to_string(first_v_line_) + ") has " + (coloured_ ? "one" : "none") +
                          ": every v line must have a colour or none");
    }
    if (coloured) mesh_.colors.emplace_back(extra[0], extra[1], extra[2]);
  }

  void texcoord(int ln, Line& line) {
    const double u = number(ln, line, "u of vt");
    const double v = number(ln, line, "v of vt");
    if (!line.at_end()) {
      number(ln, line, "w of vt");  // validated, then ignored (3D texture coordinate)
      if (!line.at_end()) fail(path_, ln, "expected 2 or 3 numbers after vt, found more");
    }
    mesh_.texcoords.emplace_back(u, v);
  }

  int index(int ln, std::string_view tok, size_t count, const char* what) {
    long i;
    if (tok.empty() || !parse_long(tok, i))
      fail(path_, ln, std::string("expected an integer ") + what + " index, found " + in_quotes(tok));
    const long n = static_cast<long>(count);
    if (i == 0) fail(path_, ln, std::string(what) + " index 0 is invalid (OBJ indices start at 1; negative ones count back)");
    const long r = i > 0 ? i - 1 : n + i;
    if (r < 0 || r >= n)
      fail(path_, ln, std::string(what) + " index " + std::to_string(i) + " out of range (" + std::to_string(n) + " " + what + " defined so far)");
    return static_cast<int>(r);
  }

  void face(int ln, Line& line) {
    corners_.clear();
    for (std::string_view tok = line.token(); !tok.empty(); tok = line.token()) {
      const size_t s1 = tok.find('/');
      Corner c{kNoIndex, kNoIndex, kNoIndex};
      c.v = index(ln, tok.substr(0, s1), mesh_.positions.size(), "v");
      if (s1 != std::string_view::npos) {
        const std::string_view r1 = tok.substr(s1 + 1);
        const size_t s2 = r1.find('/');
        const std::string_view t_vt = r1.substr(0, s2);
        if (!t_vt.empty()) c.vt = index(ln, t_vt, mesh_.texcoords.size(), "vt");
        if (s2 != std::string_view::npos) {
          const std::string_view t_vn = r1.substr(s2 + 1);
          if (t_vn.find('/') != std::string_view::npos)
            fail(path_, ln, "expected a face corner v, v/vt, v//vn, v/vt/ or v/vt/vn, found " + in_quotes(tok));
          if (!t_vn.empty()) c.vn = index(ln, t_vn, mesh_.normals.size(), "vn");
        }
      }
      corners_.push_back(c);
    }
    if (corners_.size() < 3)
      fail(path_, ln, "expected a face with at least 3 corners, found " + std::to_string(corners_.size()));
    const bool has_vt = corners_[0].vt != kNoIndex;
    const bool has_vn = corners_[0].vn != kNoIndex;
    for (const Corner& c : corners_) {
      if ((c.vt != kNoIndex) != has_vt)
        fail(path_, ln, "face mixes corners with and without texture coordinates (expected vt on every corner or on none)");
      if ((c.vn != kNoIndex) != has_vn)
        fail(path_, ln, "face mixes corners with and without normals (expected vn on every corner or on none)");
    }
    if (group_pending_) resolve_group();
    Face f;
    f.material = material_;
    f.page = has_vt && material_ != kNoIndex ? page_of_material_[static_cast<size_t>(material_)] : kNoPage;
    f.group = group_;
    f.source_line = ln;
    // Fan triangulation around the first corner: triangle k = (0, k+1, k+2).
    for (size_t k = 0; k + 2 < corners_.size(); ++k) {
      const Corner* c[3] = {&corners_[0], &corners_[k + 1], &corners_[k + 2]};
      for (int j = 0; j < 3; ++j) {
        f.v[static_cast<size_t>(j)] = c[j]->v;
        f.vt[static_cast<size_t>(j)] = c[j]->vt;
        f.vn[static_cast<size_t>(j)] = c[j]->vn;
      }
      f.polygon_corner = static_cast<int>(k);
      mesh_.faces.push_back(f);
    }
  }

  void group(Line& line, std::string_view kw) {
    // note: a group is registered when the first face under it is read, so `groups` holds only
    // groups that own faces, in order of first use; the writer emits exactly these, and a written
    // file reads back with the same group indices. A bare `g`/`o` returns to the default group.
    const std::string_view names = line.rest();
    pending_group_.clear();
    if (!names.empty()) {
      pending_group_.assign(kw);
      pending_group_ += ' ';
      pending_group_ += names;
    }
    group_pending_ = true;
  }

  void resolve_group() {
    group_pending_ = false;
    if (pending_group_.empty()) {
      group_ = kNoIndex;
      return;
    }
    const auto it = group_index_.find(pending_group_);
    if (it != group_index_.end()) {
      group_ = it->second;
      return;
    }
    group_ = static_cast<int>(mesh_.groups.size());
    group_index_.emplace(pending_group_, group_);
    mesh_.groups.push_back(pending_group_);
  }

  void smoothing(int ln, Line& line) {
    // note: smoothing groups only affect normal generation; faces keep their own normals, so the
    // statement is validated and not stored (documented in docs/io.md).
    const std::string_view tok = line.token();
    long n;
    if (tok.empty() || !(tok == "off" || (parse_long(tok, n) && n >= 0)) || !line.at_end())
      fail(path_, ln, "expected a smoothing group number or 'off' after s");
  }

  void usemtl(int ln, Line& line) {
    const std::string name(line.rest());
    if (name.empty()) fail(path_, ln, "expected a material name after usemtl");
    const auto it = material_index_.find(name);
    if (it == material_index_.end())
      fail(path_, ln, "usemtl of unknown material " + in_quotes(name) + (mtl_files_.empty() ? std::string(" (no mtllib before it)") : " (not defined in any mtllib read so far)"));
    material_ = it->second;
  }

  void mtllib(int ln, Line& line) {
    const std::string_view rest = line.rest();
    if (rest.empty()) fail(path_, ln, "expected one or more MTL file names after mtllib");
    std::vector<std::string> names;
    std::error_code ec;
    // note: names are blank-separated, but exporters also write one file name with blanks in it;
    // take the whole rest as one name when such a file exists.
    if (fs::exists(dir_ / std::string(rest), ec)) {
      names.emplace_back(rest);
    } else {
      Line split{rest.data(), rest.data() + rest.size()};
      for (std::string_view t = split.token(); !t.empty(); t = split.token()) names.emplace_back(t);
    }
    const std::string context = path_ + ":" + std::to_string(ln) + ": ";
    for (const std::string& name : names) {
      const fs::path mtl = (dir_ / name).lexically_normal();
      if (!fs::is_regular_file(mtl, ec))
        fail(path_, ln, "material library " + in_quotes(name) + " not found (looked for " + mtl.string() + ")");
      const std::string key = fs::weakly_canonical(mtl, ec).string();
      if (std::find(mtl_files_.begin(), mtl_files_.end(), key) != mtl_files_.end()) continue;
      mtl_files_.push_back(key);
      mesh_.source_files.push_back(mtl.string());
      const size_t first = mesh_.materials.size();
      MtlState st{mesh_, material_index_, material_sources_};
      read_mtl(mtl.string(), context, st);
      for (size_t m = first; m < mesh_.materials.size(); ++m) add_page(m, mtl.parent_path());
    }
  }

  void add_page(size_t m, const fs::path& mtl_dir) {
    const Material& mat = mesh_.materials[m];
    if (mat.map_kd.empty()) {
      page_of_material_.push_back(kNoPage);
      return;
    }
    page_of_material_.push_back(static_cast<int>(mesh_.pages.size()));
    Page p;
    p.material = mat.name;
    p.image_path = resolve_texture(mtl_dir, mat.map_kd).string();
    p.clamp = mat.clamp;
    mesh_.pages.push_back(std::move(p));
    page_material_.push_back(m);
  }

  /// Checks page images and reads their sizes (after the whole OBJ parsed without error).
  void finish_pages() {
    for (size_t i = 0; i < mesh_.pages.size(); ++i) {
      Page& p = mesh_.pages[i];
      const MaterialSource& src = material_sources_[page_material_[i]];
      std::error_code ec;
      if (!fs::is_regular_file(p.image_path, ec)) {
        if (!options_.require_textures) continue;
        fail(src.file, src.map_line, "texture image " + in_quotes(mesh_.materials[page_material_[i]].map_kd) + " of material " + in_quotes(p.material) + " not found (looked for " + p.image_path + ")");
      }
      if (!options_.read_page_sizes) continue;
      try {
        read_image_size(p.image_path, p.width, p.height);
      } catch (const ImageError& e) {
        fail(src.file, src.map_line, std::string("cannot read the texture image header: ") + e.what());
      }
    }
  }

  const std::string path_;
  const ObjReadOptions options_;
  fs::path dir_;
  TexturedMesh mesh_;
  int first_v_line_ = 0;   ///< line of the first `v` statement
  bool coloured_ = false;  ///< whether the first `v` line has a colour (then all must)
  std::vector<Corner> corners_;
  int material_ = kNoIndex;
  int group_ = kNoIndex;
  std::string pending_group_;   ///< the last g/o statement, "" for the default group
  bool group_pending_ = false;  ///< a g/o statement was read since the last face
  std::unordered_map<std::string, int> material_index_;
  std::unordered_map<std::string, int> group_index_;
  std::vector<MaterialSource> material_sources_;
  std::vector<int> page_of_material_;  ///< material -> page or kNoPage
  std::vector<size_t> page_material_;  ///< page -> material
  std::vector<std::string> mtl_files_; ///< canonical paths of MTLs read
};

// ---------------------------------------------------------------------------------------------
// Writer helpers.

void append_double(std::string& out, double d) {
  char buf[64];
  const auto r = std::to_chars(buf, buf + sizeof buf, d);
  out.append(buf, static_cast<size_t>(r.ptr - buf));
}

void append_int(std::string& out, long i) {
  char buf[32];
  const auto r = std::to_chars(buf, buf + sizeof buf, i);
  out.append(buf, static_cast<size_t>(r.ptr - buf));
}

/// Formats items [0, n) with line(out, i) in blocks on the framework's threads and appends the
/// blocks to `pieces` in order (`bytes` = expected bytes per item, for reserving).
template <class F>
void format_blocks(std::vector<std::string>& pieces, size_t n, size_t bytes, const F& line) {
  constexpr size_t kBlock = 1 << 12;
  const size_t blocks = (n + kBlock - 1) / kBlock, first = pieces.size();
  pieces.resize(first + blocks);
  parallel_for(blocks, [&](size_t b) {
    std::string& out = pieces[first + b];
    const size_t lo = b * kBlock, hi = std::min(n, lo + kBlock);
    out.reserve(bytes * (hi - lo));
    for (size_t i = lo; i < hi; ++i) line(out, i);
  });
}

std::string face_label(const TexturedMesh& mesh, size_t f) {
  std::string s = "face " + std::to_string(f);
  if (mesh.faces[f].source_line > 0) s += " (source line " + std::to_string(mesh.faces[f].source_line) + ")";
  return s;
}

/// Non-empty, one line, no leading or trailing blank: reads back as written.
bool is_clean_name(const std::string& s) {
  return !s.empty() && s.find_first_of("\r\n") == std::string::npos && !is_space(s.front()) && !is_space(s.back());
}

fs::path canonical_or_absolute(const fs::path& p) {
  std::error_code ec;
  fs::path c = fs::weakly_canonical(p, ec);
  if (ec) c = fs::absolute(p, ec).lexically_normal();
  return c;
}

}  // namespace

// ---------------------------------------------------------------------------------------------

TexturedMesh read_obj(const std::string& path, const ObjReadOptions& options) {
  return ObjReader(path, options).read();
}

std::string format_double(double d) {
  std::string s;
  append_double(s, d);
  return s;
}

void write_file_atomic(const std::string& path, const std::string& data) {
  write_file_atomic(path, std::vector<std::string_view>{data});
}

void write_file_atomic(const std::string& path, const std::vector<std::string>& pieces) {
  write_file_atomic(path, std::vector<std::string_view>(pieces.begin(), pieces.end()));
}

void write_file_atomic(const std::string& path, const std::vector<std::string_view>& pieces) {
  static std::atomic<unsigned> counter{0};
  const fs::path target(path);
  if (target.filename().empty()) throw ObjError(path + ": not a file name");
  const fs::path tmp = target.parent_path() / ("." + target.filename().string() + ".tmp-" +
                                               std::to_string(::getpid()) + "-" + std::to_string(counter++));
  std::FILE* f = std::fopen(tmp.c_str(), "wb");
  if (!f) throw ObjError(path + ": cannot create " + tmp.string() + ": " + std::strerror(errno));
  bool written = true;
  for (const std::string_view data : pieces)
    if (written && !data.empty()) written = std::fwrite(data.data(), 1, data.size(), f) == data.size();
  const int write_errno = errno;
  const bool closed = std::fclose(f) == 0;
  std::error_code ec;
  if (!written || !closed) {
    fs::remove(tmp, ec);
    throw ObjError(path + ": write failed: " + std::strerror(written ? errno : write_errno));
  }
  if (std::rename(tmp.c_str(), target.c_str()) != 0) {
    const int e = errno;
    fs::remove(tmp, ec);
    throw ObjError(path + ": cannot rename " + tmp.string() + " to it: " + std::strerror(e));
  }
}

namespace {

// write_obj's steps: check everything, format the MTL and the OBJ in memory, then write both.

/// Refuses an OBJ path that is not a file name, an MTL that names the OBJ itself, and either file
/// under options.protected_paths (the same rule as the write service's, io/output_set.h).
void check_output_paths(const std::string& obj_path, const fs::path& obj, const fs::path& mtl,
                        const std::string& mtl_name, const ObjWriteOptions& options) {
  const fs::path c_obj = canonical_or_absolute(obj), c_mtl = canonical_or_absolute(mtl);
  if (c_obj == c_mtl) throw ObjError(obj_path + ": the MTL name " + in_quotes(mtl_name) + " names the OBJ itself");
  // note: the same check as the write service's (io/output_set.h): canonical, and a protected
  // folder protects everything inside it.
  std::string prot = protected_match(obj.string(), options.protected_paths);
  if (!prot.empty()) throw ObjError(obj_path + ": refusing to overwrite the protected file " + prot);
  prot = protected_match(mtl.string(), options.protected_paths);
  if (!prot.empty()) throw ObjError(mtl.string() + ": refusing to overwrite the protected file " + prot);
}

/// Checks that materials and pages agree (clean unique material names, extra lines that are one
/// line and not newmtl/map_Kd, each page naming one material, at most one page per material, each
/// page with an image file name) and that groups are one-line `g`/`o` statements. Returns each
/// material's page (kNoPage for a material without one).
std::vector<int> check_materials_and_groups(const TexturedMesh& mesh, const std::string& obj_path) {
  std::unordered_map<std::string, size_t> material_of_name;
  for (size_t m = 0; m < mesh.materials.size(); ++m) {
    const Material& mat = mesh.materials[m];
    if (!is_clean_name(mat.name))
      throw ObjError(obj_path + ": material " + std::to_string(m) + " has name " + in_quotes(mat.name) + " (expected non-empty, no line break, no leading or trailing blank)");
    for (const std::string& l : mat.extra_lines) {
      Line probe{l.data(), l.data() + l.size()};
      const std::string_view kw = probe.token();
      if (l.find_first_of("\r\n") != std::string::npos || kw == "newmtl" || kw == "map_Kd" || kw == "map_kd")
        throw ObjError(obj_path + ": material " + in_quotes(mat.name) + " has extra line " + in_quotes(l) + " (expected one line that is not newmtl or map_Kd)");
    }
    if (!material_of_name.emplace(mesh.materials[m].name, m).second)
      throw ObjError(obj_path + ": two materials named " + in_quotes(mesh.materials[m].name));
  }
  std::vector<int> page_of_material(mesh.materials.size(), kNoPage);
  for (size_t p = 0; p < mesh.pages.size(); ++p) {
    const auto it = material_of_name.find(mesh.pages[p].material);
    if (it == material_of_name.end())
      throw ObjError(obj_path + ": page " + std::to_string(p) + " names material " + in_quotes(mesh.pages[p].material) + ", which is not in the mesh");
    if (page_of_material[it->second] != kNoPage)
      throw ObjError(obj_path + ": pages " + std::to_string(page_of_material[it->second]) + " and " + std::to_string(p) + " share material " + in_quotes(mesh.pages[p].material));
    if (fs::path(mesh.pages[p].image_path).filename().empty())
      throw ObjError(obj_path + ": page " + std::to_string(p) + " has no image file name");
    page_of_material[it->second] = static_cast<int>(p);
  }

  for (size_t g = 0; g < mesh.groups.size(); ++g) {
    const std::string& text = mesh.groups[g];
    if (!is_clean_name(text) || text.size() < 3 || (text[0] != 'g' && text[0] != 'o') || !is_space(text[1]))
      throw ObjError(obj_path + ": group " + std::to_string(g) + " is " + in_quotes(text) + " (expected a statement 'g NAME' or 'o NAME' on one line)");
  }
  return page_of_material;
}

/// The MTL text: one newmtl block per material, its extra lines, and map_Kd (with its options)
/// naming the file of the material's page, if it has one.
std::string format_mtl(const TexturedMesh& mesh, const std::vector<int>& page_of_material) {
  std::string m_out = "# written by texdefrag\n";
  for (size_t m = 0; m < mesh.materials.size(); ++m) {
    const Material& mat = mesh.materials[m];
    m_out += "\nnewmtl " + mat.name + "\n";
    for (const std::string& l : mat.extra_lines) {
      m_out += l;
      m_out += '\n';
    }
    if (page_of_material[m] != kNoPage) {
      m_out += "map_Kd ";
      if (!mat.map_kd_options.empty()) m_out += mat.map_kd_options + " ";
      m_out += fs::path(mesh.pages[static_cast<size_t>(page_of_material[m])].image_path).filename().string();
      m_out += '\n';
    }
  }
  return m_out;
}

/// Appends face f's lines to `out`: `g`/`usemtl` when its group or material differs from face
/// f-1's, then its `f` line. Throws ObjError naming the face when an index is out of range, a face
/// without a material follows one with, corners mix texture coordinates or normals, or its page is
/// not the one its material yields on reading back.
void format_face(std::string& out, const TexturedMesh& mesh, size_t f, const std::vector<int>& page_of_material,
                 const std::string& obj_path) {
  const Face& fc = mesh.faces[f];
  const int group = f == 0 ? kNoIndex : mesh.faces[f - 1].group;
  const int material = f == 0 ? kNoIndex : mesh.faces[f - 1].material;
  if (fc.group != group) {
    if (fc.group == kNoIndex) {
      out += "g\n";
    } else {
      if (fc.group < 0 || static_cast<size_t>(fc.group) >= mesh.groups.size())
        throw ObjError(obj_path + ": " + face_label(mesh, f) + " has group " + std::to_string(fc.group) + " out of range");
      out += mesh.groups[static_cast<size_t>(fc.group)];
      out += '\n';
    }
  }
  if (fc.material != material) {
    if (fc.material == kNoIndex)
      throw ObjError(obj_path + ": " + face_label(mesh, f) + " has no material but follows faces with one (OBJ cannot express this; order faces without a material first)");
    if (fc.material < 0 || static_cast<size_t>(fc.material) >= mesh.materials.size())
      throw ObjError(obj_path + ": " + face_label(mesh, f) + " has material " + std::to_string(fc.material) + " out of range");
    out += "usemtl " + mesh.materials[static_cast<size_t>(fc.material)].name + "\n";
  }
  const bool has_vt = fc.vt[0] != kNoIndex, has_vn = fc.vn[0] != kNoIndex;
  // The page must be the one the material yields on reading back.
  const int expected_page = has_vt && fc.material != kNoIndex ? page_of_material[static_cast<size_t>(fc.material)] : kNoPage;
  if (fc.page != expected_page)
    throw ObjError(obj_path + ": " + face_label(mesh, f) + " has page " + std::to_string(fc.page) + " but its material and texture coordinates give page " + std::to_string(expected_page));
  out += 'f';
  for (size_t k = 0; k < 3; ++k) {
    if ((fc.vt[k] != kNoIndex) != has_vt || (fc.vn[k] != kNoIndex) != has_vn)
      throw ObjError(obj_path + ": " + face_label(mesh, f) + " mixes corners with and without texture coordinates or normals");
    if (fc.v[k] < 0 || static_cast<size_t>(fc.v[k]) >= mesh.positions.size() ||
        (has_vt && (fc.vt[k] < 0 || static_cast<size_t>(fc.vt[k]) >= mesh.texcoords.size())) ||
        (has_vn && (fc.vn[k] < 0 || static_cast<size_t>(fc.vn[k]) >= mesh.normals.size())))
      throw ObjError(obj_path + ": " + face_label(mesh, f) + " has an index out of range");
    out += ' ';
    append_int(out, fc.v[k] + 1L);
    if (has_vt || has_vn) {
      out += '/';
      if (has_vt) append_int(out, fc.vt[k] + 1L);
      if (has_vn) {
        out += '/';
        append_int(out, fc.vn[k] + 1L);
      }
    }
  }
  out += '\n';
}

/// The OBJ text as pieces written in order: header (and mtllib when there are materials), then
/// v, vt, vn and face lines. The lines of each section are formatted in blocks on the framework's
/// threads and written in order, so the file does not depend on the thread count (and an error
/// names the first bad element, as a sequential pass would). Non-finite numbers are an error.
std::vector<std::string> format_obj(const TexturedMesh& mesh, const std::string& mtl_name,
                                    const std::vector<int>& page_of_material, const std::string& obj_path) {
  std::vector<std::string> pieces;
  pieces.push_back("# written by texdefrag\n");
  if (!mesh.materials.empty()) pieces.back() += "mtllib " + mtl_name + "\n";
  auto check_finite = [&](const double* d, int n, const char* what, size_t i) {
    for (int k = 0; k < n; ++k)
      if (!std::isfinite(d[k])) throw ObjError(obj_path + ": " + what + " " + std::to_string(i) + " is not finite");
  };
  if (!mesh.colors.empty() && mesh.colors.size() != mesh.positions.size())
    throw ObjError(obj_path + ": " + std::to_string(mesh.colors.size()) + " vertex colours for " +
                   std::to_string(mesh.positions.size()) + " positions (a TexturedMesh has one per position or none)");
  const bool coloured = !mesh.colors.empty();
  format_blocks(pieces, mesh.positions.size(), coloured ? 96 : 48, [&](std::string& out, size_t i) {
    const Vec3& p = mesh.positions[i];
    check_finite(p.data(), 3, "position", i);
    out += "v ";
    append_double(out, p.x());
    out += ' ';
    append_double(out, p.y());
    out += ' ';
    append_double(out, p.z());
    if (coloured) {
      const Vec3& c = mesh.colors[i];
      check_finite(c.data(), 3, "vertex colour", i);
      for (int k = 0; k < 3; ++k) {
        out += ' ';
        append_double(out, c[k]);
      }
    }
    out += '\n';
  });
  format_blocks(pieces, mesh.texcoords.size(), 40, [&](std::string& out, size_t i) {
    const Vec2& t = mesh.texcoords[i];
    check_finite(t.data(), 2, "texture coordinate", i);
    out += "vt ";
    append_double(out, t.x());
    out += ' ';
    append_double(out, t.y());
    out += '\n';
  });
  format_blocks(pieces, mesh.normals.size(), 48, [&](std::string& out, size_t i) {
    const Vec3& n = mesh.normals[i];
    check_finite(n.data(), 3, "normal", i);
    out += "vn ";
    append_double(out, n.x());
    out += ' ';
    append_double(out, n.y());
    out += ' ';
    append_double(out, n.z());
    out += '\n';
  });
  // note: a face prints `g`/`usemtl` when its group or material differs from the previous face's,
  // so a block starts from the face before it, exactly as the sequential pass would.
  format_blocks(pieces, mesh.faces.size(), 40, [&](std::string& out, size_t f) {
    format_face(out, mesh, f, page_of_material, obj_path);
  });
  return pieces;
}

}  // namespace

void write_obj(const TexturedMesh& mesh, const std::string& obj_path, const ObjWriteOptions& options) {
  const fs::path obj(obj_path);
  if (obj.filename().empty()) throw ObjError(obj_path + ": not a file name");
  const std::string mtl_name = options.mtl_name.empty() ? obj.stem().string() + ".mtl" : options.mtl_name;
  const fs::path mtl = obj.parent_path() / mtl_name;
  check_output_paths(obj_path, obj, mtl, mtl_name, options);
  const std::vector<int> page_of_material = check_materials_and_groups(mesh, obj_path);
  const std::string m_out = format_mtl(mesh, page_of_material);
  const std::vector<std::string> pieces = format_obj(mesh, mtl_name, page_of_material, obj_path);
  if (!mesh.materials.empty()) write_file_atomic(mtl.string(), m_out);
  write_file_atomic(obj_path, pieces);
}

}  // namespace texdefrag
