#pragma once
// Folders for the files a test writes (configs, result CSVs and their lock files), under one folder of
// this test process's own that is removed when the process ends. A folder shared by every run of the
// suite would let a run killed mid-way leave a CSV's lock behind, and the next run's tests fail on it.

#include <unistd.h>

#include <filesystem>
#include <string>
#include <system_error>

namespace sahbench::test {

/// <temp>/sahbench_test_<pid>/<name>, created. A folder left with this pid by an earlier, killed process
/// is removed first: the pid is this process's now, so nothing else is writing there.
inline std::filesystem::path process_temp_dir(const std::string& name) {
  static const struct Root {
    std::filesystem::path path =
        std::filesystem::temp_directory_path() / ("sahbench_test_" + std::to_string(::getpid()));
    Root() {
      std::error_code ec;
      std::filesystem::remove_all(path, ec);
    }
    ~Root() {
      std::error_code ec;
      std::filesystem::remove_all(path, ec);
    }
  } root;
  const auto dir = root.path / name;
  std::filesystem::create_directories(dir);
  return dir;
}

}  // namespace sahbench::test
