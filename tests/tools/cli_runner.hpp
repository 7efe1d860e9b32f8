#pragma once

// Runs a tool binary the way a user does, capturing exit code, stdout and stderr.

#include <sys/wait.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "support/temp_dir.hpp"

namespace dco::tools::testing {

using dco::testing::TempDir;

struct CliRun {
  int exit_code = -1;
  std::string out, err;
};

inline std::string slurp(const std::filesystem::path& path) {
  return dco::testing::read_file(path);
}

// Arguments are single-quoted for the shell; none of ours contains a quote.
inline CliRun run_cli(const std::string& exe, const TempDir& dir,
                      const std::vector<std::string>& args) {
  std::string command = "'" + exe + "'";
  for (const std::string& a : args) command += " '" + a + "'";
  const auto out = dir.path() / "stdout.txt", err = dir.path() / "stderr.txt";
  command += " >'" + out.string() + "' 2>'" + err.string() + "'";
  const int status = std::system(command.c_str());
  CliRun r;
  r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  r.out = slurp(out);
  r.err = slurp(err);
  return r;
}

// The tool failed with `exit_code` and said so on exactly one stderr line naming `fragment`.
inline void expect_one_error_line(const CliRun& r, const std::string& tool, int exit_code,
                                  const std::string& fragment) {
  EXPECT_EQ(r.exit_code, exit_code) << r.err;
  EXPECT_THAT(r.err, ::testing::StartsWith(tool + ": error: "));
  EXPECT_THAT(r.err, ::testing::HasSubstr(fragment));
  EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
}

}  // namespace dco::tools::testing
