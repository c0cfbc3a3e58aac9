// Records of a batch: derived metrics, the flattened CSV and the per-configuration summary
// (docs/bench.md). eval/plots/plots.py reads the same derived columns from results.csv.
#include "texdefrag/eval/bench.h"

#include "texdefrag/io/obj.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <limits>
#include <map>
#include <set>
#include <sstream>

namespace texdefrag::bench {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

/// The number at a JSON pointer, or NaN when absent or not a number.
double num_at(const json& j, const char* pointer) {
  const json::json_pointer p(pointer);
  if (!j.contains(p)) return std::nan("");
  const json& v = j.at(p);
  return v.is_number() ? v.get<double>() : std::nan("");
}

json opt(double d) { return std::isnan(d) ? json(nullptr) : json(d); }

struct Derived {
  const char* name;
  int direction;  // +1 larger is better, -1 smaller is better, 0 neither
};

// The derived metrics, in table order (documented in docs/bench.md).
const Derived kDerived[] = {
    {"chart_reduction", +1},        {"chart_reduction_nonzero", +1}, {"uv_border_reduction", +1},
    {"seam_3d_reduction", +1},      {"distortion_arap", -1},         {"distortion_sym_dirichlet", -1},
    {"flipped_faces", -1},          {"texture_mp_change", -1},       {"texture_bytes_change", -1},
    {"replication_in", 0},          {"replication_out", -1},         {"charts_in", 0},
    {"charts_out", 0},              {"packing_efficiency_out", +1},  {"uv_overlaps_out", -1},
    {"psnr_db", +1},                {"copied_fraction", +1},         {"lost_faces", -1},
    {"time_s", -1},                 {"peak_rss_mb", -1},
    // Appearance measures (docs/eval.md "Appearance"): clashes at MIP levels 2 and 4, seam colour
    // at levels 0 (no suffix), 2 and 4, rendered-view PSNR / SSIM per distance step _l<d> (output,
    // and input, vs the prefiltered input).
    {"clash_fraction_l2_in", 0},    {"clash_fraction_l2_out", -1},   {"clash_fraction_l4_in", 0},
    {"clash_fraction_l4_out", -1},  {"seam_colour_in", 0},           {"seam_colour_out", -1},
    {"seam_colour_l2_in", 0},       {"seam_colour_l2_out", -1},      {"seam_colour_l4_in", 0},
    {"seam_colour_l4_out", -1},
    {"rendered_psnr_l0", +1},       {"rendered_psnr_l1", +1},        {"rendered_psnr_l2", +1},
    {"rendered_psnr_l3", +1},       {"rendered_psnr_l4", +1},        {"rendered_ssim_l0", +1},
    {"rendered_ssim_l1", +1},       {"rendered_ssim_l2", +1},        {"rendered_ssim_l3", +1},
    {"rendered_ssim_l4", +1},       {"input_rendered_psnr_l0", 0},   {"input_rendered_psnr_l1", 0},
    {"input_rendered_psnr_l2", 0},  {"input_rendered_psnr_l3", 0},   {"input_rendered_psnr_l4", 0},
    {"input_rendered_ssim_l0", 0},  {"input_rendered_ssim_l1", 0},   {"input_rendered_ssim_l2", 0},
    {"input_rendered_ssim_l3", 0},  {"input_rendered_ssim_l4", 0},
};

const char* const kFixedColumns[] = {"config", "base_config", "kind", "sweep_key", "sweep_value",
                                     "model", "status", "failed_step", "error"};

void flatten(const json& j, const std::string& prefix, std::map<std::string, const json*>& out) {
  if (j.is_object()) {
    for (const auto& [k, v] : j.items()) flatten(v, prefix.empty() ? k : prefix + "." + k, out);
  } else {
    out[prefix] = &j;
  }
}

std::string csv_quote(const std::string& s) {
  if (s.find_first_of(",\"\n\r") == std::string::npos) return s;
  std::string r = "\"";
  for (char c : s) {
    if (c == '"') r += '"';
    r += c;
  }
  return r + "\"";
}

std::string csv_cell(const json& v) {
  if (v.is_null()) return "";
  if (v.is_string()) return csv_quote(v.get<std::string>());
  if (v.is_number_float()) {
    const double d = v.get<double>();
    if (std::isinf(d)) return d > 0 ? "inf" : "-inf";
    if (std::isnan(d)) return "";
  }
  if (v.is_array()) {
    const std::string s = v.dump();
    return csv_quote(s.size() <= 200 ? s : "[" + std::to_string(v.size()) + " items]");
  }
  return csv_quote(v.dump());
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const size_t n = v.size();
  if (n == 0) return std::nan("");
  if (n % 2) return v[n / 2];
  const double a = v[n / 2 - 1], b = v[n / 2];
  if (std::isinf(a) && std::isinf(b) && a == b) return a;
  return 0.5 * (a + b);
}

/// Finite numbers as JSON; infinities as the strings "inf"/"-inf"; NaN as null.
json stat_value(double d) {
  if (std::isnan(d)) return nullptr;
  if (std::isinf(d)) return d > 0 ? "inf" : "-inf";
  return d;
}

}  // namespace

int metric_direction(const std::string& name) {
  for (const Derived& d : kDerived)
    if (name == d.name) return d.direction;
  return 0;
}

namespace {

/// The appearance columns of derived_metrics (null when the record has no such measure).
void appearance_metrics(const json& r, json& d) {
  for (const char* side : {"in", "out"}) {
    const std::string which = side[0] == 'i' ? "input" : "output";
    for (int level : {2, 4}) {
      const std::string p = "/eval/texel_clashes/" + which + "/" + std::to_string(level) + "/fraction";
      d["clash_fraction_l" + std::to_string(level) + "_" + side] = opt(num_at(r, p.c_str()));
    }
    d[std::string("seam_colour_") + side] = opt(num_at(r, ("/eval/seam_colour/" + which + "/mean").c_str()));
    for (int level : {2, 4}) {
      const std::string p = "/eval/seam_colour/" + which + "/levels/" + std::to_string(level) + "/mean";
      d["seam_colour_l" + std::to_string(level) + "_" + side] = opt(num_at(r, p.c_str()));
    }
  }
  for (int level = 0; level <= 4; ++level) {
    const std::string base = "/eval/rendered/levels/" + std::to_string(level) + "/";
    const bool rendered = num_at(r, (base + "pixels").c_str()) > 0;
    for (const char* who : {"output", "input"}) {
      // PSNR of identical renders is +infinity (null in the metrics report).
      double psnr = num_at(r, (base + who + "_psnr_db").c_str());
      if (std::isnan(psnr) && rendered) psnr = kInf;
      const std::string prefix = who[0] == 'o' ? "rendered_" : "input_rendered_";
      d[prefix + "psnr_l" + std::to_string(level)] = std::isnan(psnr) ? json(nullptr) : json(psnr);
      d[prefix + "ssim_l" + std::to_string(level)] = opt(num_at(r, (base + who + "_ssim").c_str()));
    }
  }
}

}  // namespace

json derived_metrics(const json& r) {
  json d = json::object();
  const double nan = std::nan("");
  auto neg = [](double x) { return 0.0 - x; };  // never -0 (NaN stays NaN)
  d["chart_reduction"] = opt(neg(num_at(r, "/eval/relative_change/charts")));
  d["chart_reduction_nonzero"] = opt(neg(num_at(r, "/eval/relative_change/charts_nonzero_area")));
  d["uv_border_reduction"] = opt(neg(num_at(r, "/eval/relative_change/uv_border_length_texels")));
  d["seam_3d_reduction"] = opt(neg(num_at(r, "/eval/relative_change/seam_length_3d")));
  d["distortion_arap"] = opt(num_at(r, "/eval/distortion/arap"));
  d["distortion_sym_dirichlet"] = opt(num_at(r, "/eval/distortion/symmetric_dirichlet"));
  d["flipped_faces"] = opt(num_at(r, "/eval/distortion/flipped"));
  d["texture_mp_change"] = opt(num_at(r, "/eval/relative_change/megapixels"));
  d["texture_bytes_change"] = opt(num_at(r, "/eval/relative_change/page_bytes"));
  d["replication_in"] = opt(num_at(r, "/eval/input/vertex_replication"));
  d["replication_out"] = opt(num_at(r, "/eval/output/vertex_replication"));
  d["charts_in"] = opt(num_at(r, "/eval/input/charts"));
  d["charts_out"] = opt(num_at(r, "/eval/output/charts"));
  d["packing_efficiency_out"] = opt(num_at(r, "/eval/output/packing_efficiency"));
  d["uv_overlaps_out"] = opt(num_at(r, "/eval/output/uv_overlaps"));
  // PSNR of identical colours is +infinity (written as null by the metrics report, mse = 0).
  double psnr = num_at(r, "/eval/fidelity/psnr_db");
  if (std::isnan(psnr) && num_at(r, "/eval/fidelity/mse") == 0.0 && num_at(r, "/eval/fidelity/samples") > 0) psnr = kInf;
  d["psnr_db"] = std::isnan(psnr) ? json(nullptr) : json(psnr);
  d["copied_fraction"] = opt(num_at(r, "/eval/fidelity/copied_fraction"));
  d["lost_faces"] = opt(num_at(r, "/eval/matching/lost"));
  d["time_s"] = opt(num_at(r, "/run/total_time_s"));
  // Peak memory of the whole run: the child's rusage peak, else the largest stage peak.
  double peak = num_at(r, "/run/child_max_rss_bytes");
  if (std::isnan(peak) || peak <= 0) {
    peak = nan;
    if (r.contains("run") && r["run"].contains("stages") && r["run"]["stages"].is_object())
      for (const auto& [name, s] : r["run"]["stages"].items()) {
        const double p = s.is_object() && s.contains("peak_rss_bytes") && s["peak_rss_bytes"].is_number()
                             ? s["peak_rss_bytes"].get<double>()
                             : nan;
        if (!std::isnan(p) && (std::isnan(peak) || p > peak)) peak = p;
      }
  }
  d["peak_rss_mb"] = opt(std::isnan(peak) ? nan : peak / (1024.0 * 1024.0));
  appearance_metrics(r, d);
  return d;
}

std::string record_key(const json& r) {
  std::string k = r.value("config", "") + "\x1f" + r.value("model", "");
  if (r.contains("overrides") && r["overrides"].is_array())
    for (const auto& o : r["overrides"]) k += "\x1f" + (o.is_string() ? o.get<std::string>() : o.dump());
  return k;
}

std::vector<json> read_records(const std::string& jsonl_path, size_t* bad_lines) {
  std::vector<json> records;
  std::map<std::string, size_t> index;
  size_t bad = 0;
  std::ifstream in(jsonl_path);
  std::string line;
  while (std::getline(in, line)) {
    if (line.find_first_not_of(" \t\r") == std::string::npos) continue;
    json r;
    try {
      r = json::parse(line);
    } catch (const json::exception&) {
      ++bad;
      continue;
    }
    if (!r.is_object() || !r.contains("config") || !r.contains("model")) {
      ++bad;
      continue;
    }
    const std::string key = record_key(r);
    const auto it = index.find(key);
    if (it == index.end()) {
      index[key] = records.size();
      records.push_back(std::move(r));
    } else {
      records[it->second] = std::move(r);
    }
  }
  if (bad_lines) *bad_lines = bad;
  return records;
}

void write_csv(const std::vector<json>& records, const std::string& csv_path) {
  std::vector<std::map<std::string, const json*>> flat(records.size());
  std::vector<json> derived(records.size());
  std::set<std::string> other;
  std::set<std::string> fixed(std::begin(kFixedColumns), std::end(kFixedColumns));
  for (size_t i = 0; i < records.size(); ++i) {
    flatten(records[i], "", flat[i]);
    derived[i] = derived_metrics(records[i]);
    for (const auto& [k, v] : flat[i])
      if (!fixed.count(k)) other.insert(k);
  }
  std::ostringstream s;
  std::vector<std::string> header(std::begin(kFixedColumns), std::end(kFixedColumns));
  for (const Derived& d : kDerived) header.push_back(d.name);
  header.insert(header.end(), other.begin(), other.end());
  for (size_t c = 0; c < header.size(); ++c) s << (c ? "," : "") << csv_quote(header[c]);
  s << "\n";
  for (size_t i = 0; i < records.size(); ++i) {
    bool first = true;
    auto cell = [&](const std::string& text) {
      s << (first ? "" : ",") << text;
      first = false;
    };
    for (const char* k : kFixedColumns) {
      const auto it = flat[i].find(k);
      cell(it == flat[i].end() ? "" : csv_cell(*it->second));
    }
    for (const Derived& d : kDerived) cell(csv_cell(derived[i][d.name]));
    for (const std::string& k : other) {
      const auto it = flat[i].find(k);
      cell(it == flat[i].end() ? "" : csv_cell(*it->second));
    }
    s << "\n";
  }
  write_file_atomic(csv_path, s.str());
}

json summarize(const std::vector<json>& records) {
  std::vector<std::string> labels;
  std::map<std::string, std::vector<const json*>> by_label;
  for (const json& r : records) {
    const std::string l = r.value("config", "");
    if (!by_label.count(l)) labels.push_back(l);
    by_label[l].push_back(&r);
  }
  json configs = json::object();
  std::map<std::string, std::map<std::string, double>> medians;  // metric -> label -> median
  for (const std::string& l : labels) {
    json c;
    std::map<std::string, size_t> status;
    std::map<std::string, std::vector<double>> values;
    const json* any = by_label[l].front();
    for (const json* r : by_label[l]) {
      ++status[r->value("status", "")];
      if (r->value("status", "") != "ok") continue;
      const json d = derived_metrics(*r);
      for (const Derived& m : kDerived)
        if (d[m.name].is_number()) values[m.name].push_back(d[m.name].get<double>());
    }
    c["base_config"] = any->value("base_config", "");
    c["kind"] = any->value("kind", "");
    c["sweep_key"] = any->value("sweep_key", "");
    c["sweep_value"] = any->value("sweep_value", "");
    c["records"] = by_label[l].size();
    for (const char* s : {"ok", "failed", "missing"}) c[s] = status[s];
    json metrics = json::object();
    for (const Derived& m : kDerived) {
      const auto& v = values[m.name];
      if (v.empty()) continue;
      double sum = 0;
      for (double x : v) sum += x;
      const double med = median(v);
      metrics[m.name] = {{"n", v.size()},
                         {"median", stat_value(med)},
                         {"mean", stat_value(sum / static_cast<double>(v.size()))},
                         {"min", stat_value(*std::min_element(v.begin(), v.end()))},
                         {"max", stat_value(*std::max_element(v.begin(), v.end()))}};
      if (!std::isnan(med)) medians[m.name][l] = med;
    }
    c["metrics"] = metrics;
    configs[l] = c;
  }
  json winners = json::object();
  for (const Derived& m : kDerived) {
    if (m.direction == 0 || medians[m.name].size() < 2) continue;
    double best = 0;
    std::vector<std::string> who;
    for (const std::string& l : labels) {
      const auto it = medians[m.name].find(l);
      if (it == medians[m.name].end()) continue;
      const double v = it->second * m.direction;
      if (who.empty() || v > best) {
        best = v;
        who = {l};
      } else if (v == best) {
        who.push_back(l);
      }
    }
    winners[m.name] = who;
  }
  json directions = json::object();
  for (const Derived& m : kDerived) directions[m.name] = m.direction;
  return {{"configs", configs},
          {"order", labels},
          {"winners", winners},
          {"directions", directions},
          {"note", "winners: best median over successful records (direction +1: larger is better, -1: smaller)"}};
}

}  // namespace texdefrag::bench
