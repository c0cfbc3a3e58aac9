// Folders fixed at configure time (never relative to the working directory).
#pragma once

namespace texdefrag {
const char* build_plugin_dir();    ///< the build tree's plugin folder
const char* install_plugin_dir();  ///< <prefix>/lib/texdefrag/plugins
const char* shared_data_dir();     ///< ../shared/data of the source tree (may not exist)
const char* source_dir();          ///< the repository root
const char* python_executable();   ///< Python with matplotlib, for eval/plots
}  // namespace texdefrag
