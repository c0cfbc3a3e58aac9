// The write service (io/output_set.h): only plain names under the output folder, never an input
// file, nothing visible before commit, the manifest last, one run per folder.
#include "texdefrag/io/output_set.h"

#include "texdefrag/testing/fixtures.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <sstream>

namespace fs = std::filesystem;
using namespace texdefrag;

namespace {

std::string slurp(const std::string& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

void put(const std::string& p, const std::string& text) { std::ofstream(p, std::ios::binary) << text; }

/// The message of what fn throws as OutputError, or "" when it does not throw.
template <class F>
std::string refusal(F&& fn) {
  try {
    fn();
  } catch (const OutputError& e) {
    return e.what();
  }
  return "";
}

/// Entries of `dir` (names), sorted.
std::vector<std::string> listing(const std::string& dir) {
  std::vector<std::string> v;
  for (const auto& e : fs::directory_iterator(dir)) v.push_back(e.path().filename().string());
  std::sort(v.begin(), v.end());
  return v;
}

}  // namespace

TEST(OutputSet, NamesMustBePlainRelativePaths) {
  EXPECT_EQ(relative_name_problem("model.obj"), "");
  EXPECT_EQ(relative_name_problem("tiles/a/b.png"), "");
  EXPECT_EQ(relative_name_problem("../x.obj"), "has a '..' component");
  EXPECT_EQ(relative_name_problem("a/../../x"), "has a '..' component");
  EXPECT_EQ(relative_name_problem("/tmp/x.obj"), "is an absolute path");
  EXPECT_EQ(relative_name_problem(""), "is empty");
  EXPECT_NE(relative_name_problem("a//b"), "");
  EXPECT_NE(relative_name_problem("./a"), "");
  EXPECT_NE(relative_name_problem("a\\..\\b"), "");
  EXPECT_NE(relative_name_problem(".texdefrag.lock"), "");
  EXPECT_EQ(file_stem_problem("model"), "");
  EXPECT_NE(file_stem_problem("a/b"), "");
  EXPECT_NE(file_stem_problem("../in/copy"), "");

  const std::string dir = texdefrag::testing::temp_dir();
  OutputSet out(dir + "/out", {});
  for (const char* bad : {"../escape.obj", "/abs.obj", "a/../../b.obj", ""})
    EXPECT_NE(refusal([&] { out.path_for(bad); }).find("refusing to write"), std::string::npos) << bad;
  EXPECT_FALSE(fs::exists(dir + "/escape.obj"));
}

TEST(OutputSet, SymbolicLinksCannotLeadOutOfTheFolder) {
  const std::string dir = texdefrag::testing::temp_dir();
  fs::create_directories(dir + "/out");
  fs::create_directories(dir + "/elsewhere");
  fs::create_directory_symlink(dir + "/elsewhere", dir + "/out/link");
  OutputSet out(dir + "/out", {});
  EXPECT_NE(refusal([&] { out.path_for("link/x.png"); }).find("outside the output folder"), std::string::npos);
}

TEST(OutputSet, InputFilesAndTheirFoldersAreNeverWritten) {
  // An input OBJ whose mtllib names a file in the output folder (`mtllib ../out/model.mtl`).
  const std::string dir = texdefrag::testing::temp_dir();
  fs::create_directories(dir + "/in");
  fs::create_directories(dir + "/out");
  put(dir + "/out/model.mtl", "newmtl m\n");
  const std::vector<std::string> inputs = {dir + "/in/model.obj", dir + "/in/../out/model.mtl", dir + "/in/pages"};
  OutputSet out(dir + "/out", inputs, dir + "/in/model.obj");
  const std::string e = refusal([&] { out.check("model.mtl"); });
  EXPECT_NE(e.find(dir + "/out/model.mtl: refusing to write onto the input file " + dir + "/in/../out/model.mtl"),
            std::string::npos) << e;
  EXPECT_NE(e.find("referenced by " + dir + "/in/model.obj"), std::string::npos) << e;
  EXPECT_NE(refusal([&] { out.path_for("model.mtl"); }), "");
  EXPECT_EQ(slurp(dir + "/out/model.mtl"), "newmtl m\n");
  // A protected folder protects what is inside it; the output folder cannot be inside one.
  EXPECT_NE(refusal([&] { OutputSet o2(dir + "/in/pages/sub", inputs); }).find("is, or lies inside, the input file"),
            std::string::npos);
  EXPECT_EQ(protected_match(dir + "/in/pages/a.png", inputs), dir + "/in/pages");
  EXPECT_EQ(protected_match(dir + "/in/pages2/a.png", inputs), "");
}

TEST(OutputSet, NothingIsVisibleBeforeCommitAndTheManifestComesLast) {
  const std::string dir = texdefrag::testing::temp_dir() + "/out";
  {
    OutputSet out(dir, {});
    put(out.path_for("m_page0.png"), "page");
    out.write_file("sub/m.obj", "obj");
    put(out.manifest_path_for("m.report.json"), "{}");
    EXPECT_EQ(listing(dir).size(), 2u);  // the lock and the staging folder only
    EXPECT_EQ(out.names(), (std::vector<std::string>{"m_page0.png", "sub/m.obj", "m.report.json"}));
    out.commit();
  }
  EXPECT_EQ(listing(dir), (std::vector<std::string>{"m.report.json", "m_page0.png", "sub"}));
  EXPECT_EQ(slurp(dir + "/sub/m.obj"), "obj");
}

TEST(OutputSet, AFailedRunLeavesNoFinalNameAndNoStaging) {
  const std::string base = texdefrag::testing::temp_dir();
  try {
    OutputSet out(base + "/out", {});
    put(out.path_for("m_page0.png"), "page");
    put(out.path_for("m.mtl"), "mtl");
    throw std::runtime_error("disk full while writing the OBJ");
  } catch (const std::runtime_error&) {
  }
  EXPECT_FALSE(fs::exists(base + "/out")) << "the folder it created is removed again";

  // In an existing folder with an earlier run's files: they are kept, nothing new appears.
  fs::create_directories(base + "/old");
  put(base + "/old/m.obj", "old obj");
  put(base + "/old/m.report.json", "old report");
  {
    OutputSet out(base + "/old", {});
    put(out.path_for("m_page0.png"), "page");
    out.path_for("m.obj");  // claimed, never written: commit refuses and moves nothing
    put(out.manifest_path_for("m.report.json"), "{}");
    EXPECT_NE(refusal([&] { out.commit(); }).find("never written"), std::string::npos);
  }
  EXPECT_EQ(listing(base + "/old"), (std::vector<std::string>{"m.obj", "m.report.json"}));
  EXPECT_EQ(slurp(base + "/old/m.report.json"), "old report");
}

TEST(OutputSet, TwoRunsIntoOneFolderExcludeEachOther) {
  const std::string dir = texdefrag::testing::temp_dir() + "/out";
  {
    OutputSet first(dir, {});
    const std::string e = refusal([&] { OutputSet second(dir, {}); });
    EXPECT_NE(e.find("in use by another texdefrag run"), std::string::npos) << e;
    EXPECT_NE(e.find(".texdefrag.lock"), std::string::npos) << e;
    EXPECT_NE(e.find(std::to_string(::getpid())), std::string::npos) << e;
    first.write_file("a.txt", "a");
    first.commit();
  }
  OutputSet third(dir, {});  // the lock went with the first set
  EXPECT_NE(refusal([&] { third.path_for("b.txt"); third.path_for("b.txt"); }).find("written twice"), std::string::npos);
}

TEST(OutputSet, StagingLeftByAKilledRunIsRemoved) {
  const std::string dir = texdefrag::testing::temp_dir();
  fs::create_directories(dir + "/.texdefrag-staging-1-dead");
  put(dir + "/.texdefrag-staging-1-dead/m.obj", "half");
  OutputSet out(dir, {});
  EXPECT_FALSE(fs::exists(dir + "/.texdefrag-staging-1-dead"));
}
