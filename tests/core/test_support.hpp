#pragma once

// Helpers shared by the core tests: a scratch directory and whole-file reads and writes.

#include "support/temp_dir.hpp"

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include <gtest/gtest.h>

namespace dco::test {

using TempDir = dco::testing::TempDir;

inline void write_file(const std::filesystem::path& p, const std::string& bytes) {
  std::ofstream out(p, std::ios::binary);
  out << bytes;
}

inline std::string read_file(const std::filesystem::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::ostringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

inline std::filesystem::path data_dir() {
  return std::filesystem::path(DCO_DATA_DIR);
}
inline std::filesystem::path source_dir() {
  return std::filesystem::path(DCO_SOURCE_DIR);
}

}  // namespace dco::test
