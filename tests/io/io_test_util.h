// Small helpers shared by the IO tests.
#pragma once

#include "texdefrag/io/obj.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>

namespace texdefrag::io_test {

/// Writes `content` byte for byte to dir/name (creating sub-folders) and returns the path.
inline std::string write_text(const std::string& dir, const std::string& name, const std::string& content) {
  const std::filesystem::path p = std::filesystem::path(dir) / name;
  std::filesystem::create_directories(p.parent_path());
  std::ofstream out(p, std::ios::binary);
  out << content;
  out.close();
  EXPECT_TRUE(out.good()) << p;
  return p.string();
}

/// Reads a whole file as text.
inline std::string read_text(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

/// Runs read_obj, expects an ObjError and returns its message ("" and a test failure otherwise).
inline std::string obj_error(const std::string& path, const ObjReadOptions& options = {}) {
  try {
    read_obj(path, options);
  } catch (const ObjError& e) {
    return e.what();
  }
  ADD_FAILURE() << "expected ObjError reading " << path;
  return "";
}

/// Files in dir whose name contains ".tmp" (left-over temporaries of atomic writes).
inline int count_temporaries(const std::string& dir) {
  int n = 0;
  for (const auto& e : std::filesystem::directory_iterator(dir))
    if (e.path().filename().string().find(".tmp") != std::string::npos) ++n;
  return n;
}

}  // namespace texdefrag::io_test
