// testing::temp_dir's per-process folder (<tmp>/texdefrag-tests-<pid>/): removed when a test
// program ends with every test passed, kept (and its place printed) when one fails. Runs
// temp_dir_probe, a gtest program whose Probe.Passes / Probe.Fails tests make such folders.
#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <string>

namespace fs = std::filesystem;

namespace {

struct ProbeRun {
  int status = -1;
  std::string output;
  std::string folder;  ///< the test's folder, as the probe printed it
};

ProbeRun run_probe(const std::string& filter) {
  ProbeRun r;
  const std::string cmd = std::string("'") + TEXDEFRAG_TEMP_DIR_PROBE + "' --gtest_filter=" + filter + " 2>&1";
  FILE* p = popen(cmd.c_str(), "r");
  if (!p) return r;
  char buf[4096];
  while (fgets(buf, sizeof buf, p)) r.output += buf;
  r.status = pclose(p);
  const std::string tag = "probe folder: ";
  const size_t at = r.output.find(tag);
  if (at != std::string::npos) r.folder = r.output.substr(at + tag.size(), r.output.find('\n', at) - at - tag.size());
  return r;
}

}  // namespace

TEST(TempDir, RemovedWhenEveryTestPassed) {
  const ProbeRun r = run_probe("Probe.Passes");
  ASSERT_EQ(r.status, 0) << r.output;
  ASSERT_FALSE(r.folder.empty()) << r.output;
  const fs::path root = fs::path(r.folder).parent_path();
  EXPECT_EQ(root.filename().string().rfind("texdefrag-tests-", 0), 0u) << root;
  EXPECT_FALSE(fs::exists(r.folder)) << "left behind: " << r.folder;
  EXPECT_FALSE(fs::exists(root)) << "left behind: " << root;
}

TEST(TempDir, KeptAndNamedWhenATestFails) {
  const ProbeRun r = run_probe("Probe.Fails");
  ASSERT_NE(r.status, 0) << r.output;
  ASSERT_FALSE(r.folder.empty()) << r.output;
  const fs::path root = fs::path(r.folder).parent_path();
  EXPECT_TRUE(fs::exists(fs::path(r.folder) / "file.txt")) << r.output;
  EXPECT_NE(r.output.find("this test's files are kept in " + r.folder), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("their files are kept in " + root.string()), std::string::npos) << r.output;
  std::error_code ec;
  fs::remove_all(root, ec);
}
