// texdefrag._texdefrag: the C++ side of the Python module (python/texdefrag/__init__.py wraps it).
// JSON crosses the boundary as text (json.loads on the Python side); errors become the Python
// exceptions declared here with the framework's own messages (FILE:LINE, or the config key).
#include "arrays.h"

#include "texdefrag/eval/metrics.h"
#include "texdefrag/io/image.h"
#include "texdefrag/io/obj.h"
#include "texdefrag/pipeline/pipeline.h"
#include "texdefrag/stage/describe.h"
#include "texdefrag/util/parallel.h"
#include "texdefrag/util/paths.h"

#include <pybind11/stl.h>

namespace py = pybind11;
using namespace texdefrag;

namespace {

/// A configuration given as a name or path (str) or as a JSON text (from a dict), validated.
PipelineConfig config_of(const std::string& name_or_path, const std::string& json_text,
                         const std::vector<std::string>& overrides) {
  if (!json_text.empty()) {
    json j;
    try {
      j = json::parse(json_text);
    } catch (const json::exception& e) {
      throw ConfigError({std::string("<dict>: ") + e.what()});
    }
    return parse_config(j, "<dict>", overrides);
  }
  return load_config(resolve_config(name_or_path), overrides);
}

}  // namespace

PYBIND11_MODULE(_texdefrag, m) {
  m.doc() = "texdefrag: texture defragmentation of photogrammetric building models (docs/python.md)";
  static py::exception<ConfigError> config_error(m, "ConfigError", PyExc_ValueError);
  static py::exception<ConfigNotFound> config_not_found(m, "ConfigNotFound", config_error.ptr());
  static py::exception<RegistryError> plugin_error(m, "PluginError", PyExc_RuntimeError);
  static py::exception<ObjError> model_error(m, "ModelError", PyExc_ValueError);
  static py::exception<ImageError> image_error(m, "ImageError", model_error.ptr());
  static py::exception<StageError> stage_error(m, "StageError", PyExc_RuntimeError);
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const ConfigNotFound& e) {
      PyErr_SetString(config_not_found.ptr(), e.what());
    } catch (const ConfigError& e) {
      PyErr_SetString(config_error.ptr(), e.what());
    } catch (const RegistryError& e) {
      PyErr_SetString(plugin_error.ptr(), e.what());
    } catch (const ImageError& e) {
      PyErr_SetString(image_error.ptr(), e.what());
    } catch (const ObjError& e) {
      PyErr_SetString(model_error.ptr(), e.what());
    } catch (const StageError& e) {
      PyErr_SetString(stage_error.ptr(), e.what());
    }
  });

  m.def("version", [] { return std::string(TEXDEFRAG_VERSION_STRING); });
  m.def("install_root", &install_root);
  m.def("set_threads", &set_thread_count, py::arg("n"), "Threads inside runs (0 = every core), as --threads");
  m.def("threads", &thread_count, "Threads runs use now");
  m.def("configs", &shipped_configs, "Names of the shipped configurations");
  m.def("resolve_config", &resolve_config, py::arg("name_or_path"));
  m.def("stages_json", [] { return describe_all_stages().dump(); });
  m.def(
      "config_json",
      [](const std::string& name, const std::string& text, const std::vector<std::string>& overrides) {
        return config_of(name, text, overrides).effective.dump();
      },
      py::arg("name_or_path"), py::arg("json_text"), py::arg("overrides"));
  m.def(
      "run_json",
      [](const std::string& name, const std::string& text, const std::vector<std::string>& overrides,
         const std::string& input, const std::string& output_dir, bool write) {
        const PipelineConfig cfg = config_of(name, text, overrides);
        RunOptions ro;
        ro.input = input;
        ro.output_dir = output_dir;
        ro.write_output = write;
        py::gil_scoped_release release;
        return run_pipeline(cfg, ro).dump();
      },
      py::arg("name_or_path"), py::arg("json_text"), py::arg("overrides"), py::arg("input"), py::arg("output_dir"),
      py::arg("write"));
  m.def(
      "eval_json",
      [](const std::string& in, const std::string& out, bool texture, size_t samples) {
        eval::EvalOptions o;
        o.texture = texture;
        if (samples) o.fidelity.samples = samples;
        py::gil_scoped_release release;
        return eval::to_json(eval::compare_files(in, out, o)).dump();
      },
      py::arg("input"), py::arg("output"), py::arg("texture"), py::arg("samples"));
  m.def("write_model", &python::write_model, py::arg("dir"), py::arg("stem"), py::arg("positions"), py::arg("faces"),
        py::arg("uvs"), py::arg("face_uvs"), py::arg("face_pages"), py::arg("pages"));
  m.def("read_model", &python::read_model, py::arg("obj_path"), py::arg("with_pages") = true);
}
