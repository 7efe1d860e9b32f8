#pragma once

#include <dirent.h>
#include <sys/types.h>

#include <algorithm>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

namespace dco::testing {

// The names of a process's threads (/proc/<pid>/task/<tid>/comm); `pid` 0: this process.
inline std::vector<std::string> thread_names(pid_t pid = 0) {
  const std::string tasks =
      pid == 0 ? std::string("/proc/self/task") : "/proc/" + std::to_string(pid) + "/task";
  std::vector<std::string> names;
  if (DIR* dir = opendir(tasks.c_str())) {
    while (const dirent* e = readdir(dir)) {
      if (e->d_name[0] == '.') continue;
      const std::string path = tasks + "/" + e->d_name + "/comm";
      if (FILE* f = std::fopen(path.c_str(), "r")) {
        char name[32] = {};
        if (std::fgets(name, sizeof name, f)) names.emplace_back(name, std::strcspn(name, "\n"));
        std::fclose(f);
      }
    }
    closedir(dir);
  }
  return names;
}

inline long count_named(const std::vector<std::string>& names, const std::string& name) {
  return std::count(names.begin(), names.end(), name);
}

}  // namespace dco::testing
