// Option validation, the registry's name rules and duplicate detection, and creating every
// registered stage by name.
#include "texdefrag/pipeline/pipeline.h"
#include "texdefrag/stage/registry.h"
#include "texdefrag/testing/fixtures.h"

#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>

using namespace texdefrag;

namespace {

class Dummy final : public Detector {
 public:
  void detect(StageContext&) override {}
};

StageInfo dummy_info(const std::string& name) {
  StageInfo i;
  i.name = name;
  i.kind = StageKind::Detector;
  i.description = "test";
  i.options = {opt_double("angle_deg", 25, "angle").range(0, 90).unit("deg"), opt_int("count", 3, "n").at_least(1),
               opt_enum("mode", "a", {"a", "b"}, "mode"), opt_bool("flag", false, "flag"), opt_string("path", "", "p")};
  i.create = [] { return std::make_unique<Dummy>(); };
  return i;
}

}  // namespace

TEST(Options, DefaultsAndTypedAccess) {
  const Options o = default_options(dummy_info("detectors.d"));
  EXPECT_DOUBLE_EQ(o.get_double("angle_deg"), 25.0);
  EXPECT_EQ(o.get_int("count"), 3);
  EXPECT_EQ(o.get_string("mode"), "a");
  EXPECT_FALSE(o.get_bool("flag"));
  EXPECT_THROW(o.get_double("nope"), std::logic_error);
}

TEST(Options, ErrorsNameTheKeyAndNeverClamp) {
  const StageInfo info = dummy_info("detectors.d");
  std::vector<std::string> errors;
  make_options(info, {{"angle_deg", 95}, {"count", 2.5}, {"mode", "c"}, {"flag", 1}, {"angle_treshold", 3}}, "detector", errors);
  ASSERT_EQ(errors.size(), 5u);
  auto has = [&](const std::string& fragment) {
    for (const auto& e : errors)
      if (e.find(fragment) != std::string::npos) return true;
    return false;
  };
  EXPECT_TRUE(has("detector: 'angle_deg' = 95 outside [0, 90]"));
  EXPECT_TRUE(has("detector: 'count' must be an integer, got 2.5"));
  EXPECT_TRUE(has("detector: 'flag' must be a bool, got integer"));
  EXPECT_TRUE(has("detector: 'mode' = \"c\" is not one of \"a\" \"b\""));
  EXPECT_TRUE(has("detector: unknown option 'angle_treshold' for detectors.d"));
  errors.clear();
  const Options ok = make_options(info, {{"angle_deg", 90}, {"count", 1}}, "detector", errors);
  EXPECT_TRUE(errors.empty());
  EXPECT_DOUBLE_EQ(ok.get_double("angle_deg"), 90.0);  // inclusive bounds
  EXPECT_THROW(default_options(info, {{"angle_deg", -1}}), std::invalid_argument);
}

TEST(Options, NearestSuggestion) {
  EXPECT_EQ(nearest("angle_treshold", {"angle_threshold", "gutter"}), "angle_threshold");
  EXPECT_EQ(nearest("zzzzzz", {"angle_threshold", "gutter"}), "");
  EXPECT_EQ(edit_distance("kitten", "sitting"), 3u);
}

TEST(Registry, RejectsMalformedNamesWrongKindAndDuplicates) {
  Registry r;
  EXPECT_THROW(r.add(dummy_info("Detectors.X"), "a.so"), RegistryError);
  EXPECT_THROW(r.add(dummy_info("detectors"), "a.so"), RegistryError);
  EXPECT_THROW(r.add(dummy_info("detectors."), "a.so"), RegistryError);
  EXPECT_THROW(r.add(dummy_info("detectors.9lives"), "a.so"), RegistryError);
  EXPECT_THROW(r.add(dummy_info("detectors.a-b"), "a.so"), RegistryError);
  EXPECT_THROW(r.add(dummy_info("writers.x"), "a.so"), RegistryError);
  StageInfo wrong = dummy_info("mergers.x");  // declared as a detector
  EXPECT_THROW(r.add(wrong, "a.so"), RegistryError);
  StageInfo bad_default = dummy_info("detectors.bad");
  bad_default.options[0].default_value = 100;
  EXPECT_THROW(r.add(bad_default, "a.so"), RegistryError);
  r.add(dummy_info("detectors.d"), "/plugins/first.so");
  try {
    r.add(dummy_info("detectors.d"), "/plugins/second.so");
    FAIL() << "duplicate accepted";
  } catch (const RegistryError& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find("/plugins/first.so"), std::string::npos) << msg;
    EXPECT_NE(msg.find("/plugins/second.so"), std::string::npos) << msg;
  }
  try {
    r.create("detectors.e");
    FAIL();
  } catch (const RegistryError& e) {
    EXPECT_NE(std::string(e.what()).find("did you mean 'detectors.d'"), std::string::npos);
  }
}

TEST(Registry, BrokenModuleIsAnErrorNamingTheFile) {
  const std::string dir = texdefrag::testing::temp_dir();
  const std::string path = dir + "/texdefrag_broken.so";
  FILE* f = std::fopen(path.c_str(), "w");
  std::fputs("not a shared object", f);
  std::fclose(f);
  Registry r;
  try {
    r.load_module(path);
    FAIL();
  } catch (const RegistryError& e) {
    EXPECT_NE(std::string(e.what()).find(path), std::string::npos);
  }
}

TEST(Registry, EveryBuiltStageIsCreatedByNameWithDefaults) {
  Registry& r = Registry::instance();
  r.load_plugins();
  ASSERT_NE(r.find("detectors.none"), nullptr);
  ASSERT_NE(r.find("mergers.none"), nullptr);
  ASSERT_NE(r.find("packers.shelf"), nullptr);
  const std::string file = texdefrag::testing::temp_dir() + "/input.txt";
  std::fclose(std::fopen(file.c_str(), "w"));
  for (const StageInfo* info : r.list()) {
    auto s = r.create(info->name);
    ASSERT_TRUE(s) << info->name;
    json required = json::object();  // required input files (detectors.labels' path)
    for (const OptionSpec& o : info->options)
      if (o.required && o.type == OptionType::InputPath) required[o.key] = file;
    s->set_options(default_options(*info, required));
    EXPECT_FALSE(info->description.empty()) << info->name;
    EXPECT_FALSE(info->doc.empty()) << info->name;
    for (const OptionSpec& o : info->options) EXPECT_FALSE(o.help.empty()) << info->name << "." << o.key;
  }
}

// ------------------------------------------------------------------------------------------------
// Typed options (issue 11): required, enum without fallback, input and output paths, stage
// references, and a stray library in a plugin folder.

namespace {
StageInfo typed_info() {
  StageInfo i = dummy_info("detectors.typed");
  i.options = {opt_input_path("labels", "a label file").required(), opt_output_path("write", "an output name"),
               opt_stage("other", "detectors", "another detector"), opt_enum("mode", "a", {"a", "b"}, "mode")};
  return i;
}
std::string errors_of(const StageInfo& info, const json& values) {
  std::vector<std::string> errors;
  make_options(info, values, "detector (" + info.name + ")", errors);
  std::string all;
  for (const auto& e : errors) all += e + "\n";
  return all;
}
}  // namespace

TEST(TypedOptions, ARequiredOptionMissingIsAnErrorNamingIt) {
  EXPECT_NE(errors_of(typed_info(), json::object()).find("detector (detectors.typed): 'labels' is required"), std::string::npos);
  EXPECT_NE(errors_of(typed_info(), {{"labels", ""}}).find("'labels' is required"), std::string::npos);
}

TEST(TypedOptions, InputPathsMustExistOutputNamesStayInTheOutputFolder) {
  const std::string dir = texdefrag::testing::temp_dir();
  const std::string file = dir + "/l.txt";
  std::fclose(std::fopen(file.c_str(), "w"));
  EXPECT_EQ(errors_of(typed_info(), {{"labels", file}, {"write", "regions.obj"}}), "");
  EXPECT_NE(errors_of(typed_info(), {{"labels", dir + "/missing.txt"}}).find("'labels' = \"" + dir + "/missing.txt\": no such file"),
            std::string::npos);
  for (const std::string bad : {"/tmp/x.obj", "../in/x.obj", "a/../../x.obj"})
    EXPECT_NE(errors_of(typed_info(), {{"labels", file}, {"write", bad}}).find("'write' = \"" + bad + "\""), std::string::npos) << bad;
}

TEST(TypedOptions, StageReferencesNameARegisteredStageOfTheirKind) {
  Registry::instance().load_plugins();
  const std::string dir = texdefrag::testing::temp_dir();
  const std::string file = dir + "/l.txt";
  std::fclose(std::fopen(file.c_str(), "w"));
  EXPECT_EQ(errors_of(typed_info(), {{"labels", file}, {"other", "detectors.none"}}), "");
  EXPECT_NE(errors_of(typed_info(), {{"labels", file}, {"other", "detectors.nonee"}}).find("did you mean \"detectors.none\""),
            std::string::npos);
  EXPECT_NE(errors_of(typed_info(), {{"labels", file}, {"other", "packers.shelf"}}).find("is not a registered detectors stage"),
            std::string::npos);
}

TEST(TypedOptions, EnumValuesNeverFallBackToADefault) {
  const Options o(json{{"mode", "c"}});  // not validated: what a stage could be handed by mistake
  EXPECT_THROW(o.get_enum<int>("mode", {{"a", 1}, {"b", 2}}), std::invalid_argument);
  const Options ok(json{{"mode", "b"}});
  EXPECT_EQ(ok.get_enum<int>("mode", {{"a", 1}, {"b", 2}}), 2);
}

TEST(Registry, AStrayLibraryInAPluginFolderIsSkippedWithAWarningNamingIt) {
  const std::string dir = texdefrag::testing::temp_dir();
  // A real shared library that is not a texdefrag module: the framework library itself has no entry point.
  std::string lib;
  for (const char* c : {"/usr/lib/x86_64-linux-gnu/libz.so.1", "/lib/x86_64-linux-gnu/libz.so.1"})
    if (std::filesystem::exists(c)) lib = c;
  if (lib.empty()) GTEST_SKIP() << "no libz.so.1 to copy";
  std::filesystem::copy_file(lib, dir + "/stray.so");
  setenv("TEXDEFRAG_PLUGIN_PATH", dir.c_str(), 1);
  Registry r;
  ::testing::internal::CaptureStderr();
  EXPECT_NO_THROW(r.load_plugins());
  const std::string err = ::testing::internal::GetCapturedStderr();
  unsetenv("TEXDEFRAG_PLUGIN_PATH");
  EXPECT_NE(err.find("skipping " + dir + "/stray.so: not a texdefrag plugin"), std::string::npos) << err;
  ASSERT_EQ(r.skipped().size(), 1u);
  EXPECT_NE(r.find("detectors.none"), nullptr);  // the real modules still load
}
