#include <fstream>
#include <sstream>

#include <gtest/gtest.h>

#include "dco/core/error.hpp"
#include "dco/daemon/daemon_config.hpp"
#include "dco/daemon/logger.hpp"
#include "support/temp_dir.hpp"

namespace dco::daemon {
namespace {

std::string load_error(const ConfigSources& sources) {
  try {
    load_config(sources);
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

TEST(DaemonConfig, FileThenOverridesThenSource) {
  dco::testing::TempDir dir;
  ConfigSources s;
  s.file = dir.write("dcod.toml", "[lcm]\npreview_hz = 5\n[densify]\nlambda_s = 2.5\n");
  s.sets = {"lcm.preview_hz=7", "stereo.max_disparity=48"};
  s.source = "replay:///somewhere";
  const LoadedConfig c = load_config(s);
  EXPECT_DOUBLE_EQ(c.config.preview_hz, 7);
  EXPECT_DOUBLE_EQ(c.config.pipeline.densify.lambda_s, 2.5);
  EXPECT_EQ(c.config.pipeline.stereo.max_disparity, 48);
  EXPECT_TRUE(c.max_disparity_given);
  EXPECT_EQ(c.config.source, "replay:///somewhere");
  EXPECT_FALSE(load_config({}).max_disparity_given);
}

TEST(DaemonConfig, ALogsRecordedPipelineComesBeforeTheFileAndTheSets) {
  dco::testing::TempDir dir;
  ConfigSources headset;
  headset.sets = {"stereo.max_disparity=40", "densify.lambda_s=2", "lcm.preview_hz=9",
                  "runtime.deterministic=true"};
  const std::string recorded = pipeline_keys(load_config(headset));
  EXPECT_NE(recorded.find("stereo.max_disparity=40\n"), std::string::npos) << recorded;
  EXPECT_NE(recorded.find("densify.lambda_s=2\n"), std::string::npos) << recorded;
  // Only the algorithm travels: rates, the bus and the scheduling are the desk's business.
  EXPECT_EQ(recorded.find("lcm."), std::string::npos) << recorded;
  EXPECT_EQ(recorded.find("runtime."), std::string::npos) << recorded;

  ConfigSources desk;
  desk.recorded = recorded;
  LoadedConfig c = load_config(desk);
  EXPECT_EQ(c.config.pipeline.stereo.max_disparity, 40);
  EXPECT_DOUBLE_EQ(c.config.pipeline.densify.lambda_s, 2);
  EXPECT_TRUE(c.max_disparity_given);
  EXPECT_EQ(pipeline_keys(c), recorded) << "the recorded keys reproduce themselves";
  // The engineer's file and --set win over the log.
  desk.file = dir.write("dcod.toml", "[densify]\nlambda_s = 3\n");
  desk.sets = {"stereo.max_disparity=24"};
  c = load_config(desk);
  EXPECT_EQ(c.config.pipeline.stereo.max_disparity, 24);
  EXPECT_DOUBLE_EQ(c.config.pipeline.densify.lambda_s, 3);
  // A log from another build: keys this one lacks are skipped and named; a bad value is an error.
  desk = {};
  desk.recorded = "stereo.max_disparity=32\nstereo.warp_drive=9\nring.path=/tmp/x\n";
  c = load_config(desk);
  EXPECT_EQ(c.config.pipeline.stereo.max_disparity, 32);
  EXPECT_EQ(c.recorded_skipped, (std::vector<std::string>{"stereo.warp_drive", "ring.path"}));
  EXPECT_TRUE(c.config.ring_path.empty());
  desk.recorded = "stereo.max_disparity=lots\n";
  EXPECT_NE(load_error(desk).find("the log's recorded pipeline"), std::string::npos)
      << load_error(desk);
}

TEST(DaemonConfig, PrintedConfigLoadsBackToTheSameValues) {
  dco::testing::TempDir dir;
  ConfigSources s;
  s.sets = {"service.max_frames=12", "log.level=warning", "contour.lookahead=1",
            "ring.path=/tmp/a \"quoted\" path"};
  const LoadedConfig first = load_config(s);
  ConfigSources again;
  again.file = dir.write("printed.toml", first.toml);
  const LoadedConfig second = load_config(again);
  EXPECT_EQ(first.values, second.values);
  EXPECT_EQ(second.config.ring_path, "/tmp/a \"quoted\" path");
  EXPECT_TRUE(changed_keys(first, second).empty());
}

TEST(DaemonConfig, BadInputNamesFileLineAndReason) {
  dco::testing::TempDir dir;
  ConfigSources unknown;
  unknown.file = dir.write("a.toml", "[ring]\nslots = 4\nslot = 5\n");
  EXPECT_EQ(load_error(unknown), unknown.file->string() + ":3: unknown key 'ring.slot'");

  ConfigSources range;
  range.file = dir.write("b.toml", "[ring]\n\nslots = 2\n");
  EXPECT_NE(load_error(range).find(range.file->string() + ":3: ring.slots"), std::string::npos);

  ConfigSources type;
  type.file = dir.write("c.toml", "[log]\nlevel = 3\n");
  EXPECT_NE(load_error(type).find(":2: log.level"), std::string::npos);

  ConfigSources choice;
  choice.sets = {"log.level=loud"};
  EXPECT_NE(load_error(choice).find("--set log.level=loud"), std::string::npos);

  ConfigSources syntax;
  syntax.file = dir.write("d.toml", "[service\nmax_frames = 1\n");
  EXPECT_NE(load_error(syntax).find(syntax.file->string() + ":1:"), std::string::npos);

  ConfigSources missing;
  missing.file = dir.path() / "absent.toml";
  EXPECT_NE(load_error(missing).find("cannot open"), std::string::npos);

  ConfigSources invalid;  // in range on its own, refused by the stage's validation
  invalid.sets = {"stereo.census_width=8"};
  EXPECT_NE(load_error(invalid).find("census"), std::string::npos);
  // ... and a good file is not blamed for a --set.
  invalid.file = dir.write("good.toml", "[densify]\nlambda_s = 1.2\n");
  EXPECT_NE(load_error(invalid).find("good.toml with --set: "), std::string::npos)
      << load_error(invalid);

  ConfigSources empty_source;
  empty_source.source = "";
  EXPECT_FALSE(load_error(empty_source).empty());
}

TEST(DaemonConfig, ChangedKeysAndWhatAReloadCanApply) {
  ConfigSources a, b;
  b.sets = {"densify.lambda_s=3", "lcm.preview_hz=9", "ring.slots=6", "log.level=debug"};
  const auto changed = changed_keys(load_config(a), load_config(b));
  EXPECT_EQ(changed, (std::vector<std::string>{"ring.slots", "lcm.preview_hz", "log.level",
                                               "densify.lambda_s"}));
  EXPECT_EQ(reload_kind("densify.lambda_s"), Reload::kPipeline);
  EXPECT_EQ(reload_kind("runtime.threads"), Reload::kPipeline);
  EXPECT_EQ(reload_kind("lcm.preview_hz"), Reload::kLive);
  EXPECT_EQ(reload_kind("log.level"), Reload::kLive);
  EXPECT_EQ(reload_kind("ring.slots"), Reload::kRestart);
  EXPECT_EQ(reload_kind("source.uri"), Reload::kRestart);
  EXPECT_EQ(reload_kind("lcm.url"), Reload::kRestart);
  EXPECT_EQ(reload_kind("runtime.opencv_threads"), Reload::kRestart);  // the process's
}

TEST(DaemonConfig, ShippedConfigLoads) {
  ConfigSources s;
  s.file = std::filesystem::path(DCO_SOURCE_DIR) / "systemd" / "dcod.toml";
  const LoadedConfig c = load_config(s);
  EXPECT_EQ(c.config.source, "indemind://");
  EXPECT_TRUE(c.config.ring_path.empty()) << "under systemd the ring belongs in RuntimeDirectory";
}

TEST(DaemonConfig, ReadmeDocumentsEveryKeyWithItsDefault) {
  std::ifstream in(std::filesystem::path(DCO_SOURCE_DIR) / "README.md");
  std::stringstream readme;
  readme << in.rdbuf();
  const std::string text = readme.str();
  for (const auto& [key, value] : load_config({}).values) {
    const std::string row = "| `" + key + "` | ";
    const std::size_t at = text.find(row);
    ASSERT_NE(at, std::string::npos)
        << key << " is missing from the README's configuration reference";
    const std::size_t end = text.find(" |", at + row.size());
    EXPECT_EQ(text.substr(at + row.size(), end - at - row.size()), value)
        << "the README gives another default for " << key;
  }
}

TEST(Logger, LevelsParseAndFilter) {
  EXPECT_EQ(parse_log_level("warning"), LogLevel::kWarning);
  EXPECT_THROW(parse_log_level("verbose"), Error);
  Logger log;
  std::vector<std::string> seen;
  log.set_forward([&](LogLevel, std::string_view text) { seen.emplace_back(text); });
  log.set_level(LogLevel::kWarning);
  log.info("quiet");
  log.warning("loud");
  log.error("louder");
  EXPECT_EQ(seen, (std::vector<std::string>{"loud", "louder"}));
}

TEST(Logger, AMessageStaysOneLineWithoutEscapes) {
  Logger log;
  std::vector<std::string> seen;
  log.set_forward([&](LogLevel, std::string_view text) { seen.emplace_back(text); });
  // A source URI as a user might paste it, with a line break and a terminal colour code.
  log.error("source 'synthetic://hand?fps=3\x1b[31mX\nY': fps must be a number");
  log.warning(std::string_view("a\0b\tc\x7f", 6));
  EXPECT_EQ(seen, (std::vector<std::string>{
                      "source 'synthetic://hand?fps=3?[31mX?Y': fps must be a number", "a?b?c?"}));
}

}  // namespace
}  // namespace dco::daemon
