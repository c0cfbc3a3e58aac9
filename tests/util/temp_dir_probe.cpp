// A test program for test_temp_dir (not a test itself): each test makes a folder with
// testing::temp_dir, writes a file into it and prints the folder; Probe.Fails then fails.
#include "texdefrag/testing/fixtures.h"

#include <cstdio>
#include <fstream>

TEST(Probe, Passes) {
  const std::string d = texdefrag::testing::temp_dir();
  std::ofstream(d + "/file.txt") << "kept until the program ends";
  std::printf("probe folder: %s\n", d.c_str());
}

TEST(Probe, Fails) {
  const std::string d = texdefrag::testing::temp_dir();
  std::ofstream(d + "/file.txt") << "kept: the test fails";
  std::printf("probe folder: %s\n", d.c_str());
  ADD_FAILURE() << "this test fails on purpose (test_temp_dir checks its files are kept)";
}
