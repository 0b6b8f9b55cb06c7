// Replays the fuzzers' inputs through the same reader table the fuzz targets use (fuzz/fuzz_readers.h):
// every file of fuzz/regressions/<reader> and fuzz/corpus/<reader> must load or be refused with an
// Error. Another exception type, a crash or a sanitizer report fails the test, naming the file.

#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <ostream>
#include <string>
#include <vector>

#include "fuzz/fuzz_readers.h"

namespace sahbench::fuzz {

// The reader's name in ctest's listing, not its bytes.
void PrintTo(const FuzzReader& reader, std::ostream* os) {
  *os << reader.name;
}

namespace {

const std::filesystem::path kFuzzDir = std::filesystem::path(SAHBENCH_SOURCE_DIR) / "fuzz";

// The files of `folder`, sorted; none when it does not exist.
std::vector<std::filesystem::path> files_in(const std::filesystem::path& folder) {
  std::vector<std::filesystem::path> files;
  if (!std::filesystem::is_directory(folder)) return files;
  for (const auto& entry : std::filesystem::directory_iterator(folder))
    if (entry.is_regular_file()) files.push_back(entry.path());
  std::sort(files.begin(), files.end());
  return files;
}

class FuzzReplay : public ::testing::TestWithParam<FuzzReader> {};

TEST_P(FuzzReplay, RegressionsAndSeedsLoadOrAreRefused) {
  const FuzzReader& reader = GetParam();
  std::size_t replayed = 0;
  for (const char* kind : {"regressions", "corpus"}) {
    for (const auto& file : files_in(kFuzzDir / kind / std::string(reader.name))) {
      SCOPED_TRACE(file.string());
      EXPECT_NO_THROW(read_or_refuse(reader, file));
      ++replayed;
    }
  }
  // Every reader has seeds: an empty folder means a renamed reader or a moved corpus.
  EXPECT_GT(replayed, 0u) << "no inputs for " << reader.name << " under " << kFuzzDir.string();
}

INSTANTIATE_TEST_SUITE_P(Readers, FuzzReplay,
                         ::testing::ValuesIn(fuzz_readers().begin(), fuzz_readers().end()),
                         [](const ::testing::TestParamInfo<FuzzReader>& info) {
                           return std::string(info.param.name);
                         });

}  // namespace
}  // namespace sahbench::fuzz
