#include "dco/core/file_replace.hpp"

#include <sys/stat.h>

#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <string>
#include <thread>

#include <gtest/gtest.h>

#include "dco/core/disparity_io.hpp"
#include "dco/core/error.hpp"
#include "support/file_size_limit.hpp"
#include "test_support.hpp"

namespace dco {
namespace {

long files_in(const std::filesystem::path& dir) {
  long n = 0;
  for ([[maybe_unused]] const auto& e : std::filesystem::directory_iterator(dir)) ++n;
  return n;
}

TEST(ReplaceFile, AWriteThatFailsLeavesTheEarlierFileAndNoTemporaryOne) {
  test::TempDir dir;
  const auto path = dir.path() / "out.pfm";
  test::write_file(path, "earlier");
  EXPECT_THROW(replace_file(path,
                            [&](const std::filesystem::path& tmp) {
                              EXPECT_EQ(tmp.parent_path(), path.parent_path());
                              EXPECT_EQ(tmp.extension(), ".pfm");
                              test::write_file(tmp, "half");
                              throw std::runtime_error("disk full");
                            }),
               std::runtime_error);
  EXPECT_EQ(test::read_file(path), "earlier");
  EXPECT_EQ(files_in(dir.path()), 1);
  replace_file(path, [](const std::filesystem::path& tmp) { test::write_file(tmp, "new"); });
  EXPECT_EQ(test::read_file(path), "new");
  EXPECT_EQ(files_in(dir.path()), 1);
}

TEST(ReplaceFile, ADirectoryInTheWayIsNamedWithTheReason) {
  test::TempDir dir;
  const auto path = dir.path() / "report.html";
  std::filesystem::create_directory(path);
  try {
    replace_file(path, [](const std::filesystem::path& tmp) { test::write_file(tmp, "x"); });
    FAIL() << "wrote over a directory";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("Is a directory"), std::string::npos) << e.what();
  }
  EXPECT_EQ(files_in(dir.path()), 1);
}

// A link to an output is written through: the link stays a link and the file it names gets the
// bytes, also through a chain of links and a relative one.
TEST(ReplaceFile, ALinkIsWrittenThroughNotReplaced) {
  test::TempDir dir;
  const auto real = dir.path() / "real.json";
  test::write_file(real, "old");
  std::filesystem::create_directory(dir.path() / "sub");
  std::filesystem::create_symlink("../real.json", dir.path() / "sub" / "relative.json");
  std::filesystem::create_symlink(dir.path() / "sub" / "relative.json", dir.path() / "link.json");
  replace_file(dir.path() / "link.json",
               [](const std::filesystem::path& tmp) { test::write_file(tmp, "new"); });
  EXPECT_TRUE(std::filesystem::is_symlink(dir.path() / "link.json"));
  EXPECT_TRUE(std::filesystem::is_symlink(dir.path() / "sub" / "relative.json"));
  EXPECT_EQ(test::read_file(real), "new");
  EXPECT_EQ(files_in(dir.path()), 3);  // real.json, sub, link.json: no temporary file left
  // A link to a file not there yet makes it.
  std::filesystem::create_symlink("made.pfm", dir.path() / "to_new.pfm");
  replace_file(dir.path() / "to_new.pfm",
               [](const std::filesystem::path& tmp) { test::write_file(tmp, "made"); });
  EXPECT_EQ(test::read_file(dir.path() / "made.pfm"), "made");
  EXPECT_TRUE(std::filesystem::is_symlink(dir.path() / "to_new.pfm"));
}

// A FIFO (as /dev/stdout piped to another program) is written in place, not replaced by a file.
TEST(ReplaceFile, AFifoIsWrittenInPlace) {
  test::TempDir dir;
  const auto fifo = dir.path() / "out.json";
  ASSERT_EQ(mkfifo(fifo.c_str(), 0600), 0);
  std::string got;
  std::thread reader([&] { got = test::read_file(fifo); });
  replace_file(fifo, [](const std::filesystem::path& tmp) { test::write_file(tmp, "{\"a\": 1}"); });
  reader.join();
  EXPECT_EQ(got, "{\"a\": 1}");
  EXPECT_TRUE(std::filesystem::is_fifo(fifo));
  EXPECT_EQ(files_in(dir.path()), 1);
}

// A full disk in the middle of a PFM (a file size limit here) keeps the map that was there.
TEST(ReplaceFile, APfmCutShortByTheDiskKeepsTheEarlierMap) {
  test::TempDir dir;
  const auto path = dir.path() / "d.pfm";
  Image<float> small(4, 3, 1);
  small.fill(2.5f);
  write_pfm(path, small.view());
  const std::string earlier = test::read_file(path);
  Image<float> big(256, 256, 1);
  big.fill(1.0f);
  EXPECT_EQ(
      dco::testing::status_of_write_past_file_limit(4096, [&] { write_pfm(path, big.view()); }),
      dco::testing::kWriteThrew)
      << "the cut write did not fail";
  EXPECT_EQ(test::read_file(path), earlier);
  EXPECT_EQ(files_in(dir.path()), 1);
}

}  // namespace
}  // namespace dco
