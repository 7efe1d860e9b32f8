#include "dco/core/file_replace.hpp"

#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <string>

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
