// libFuzzer target: the tree-file reader (scenes/tree_file.h) on the fuzzer's bytes, written to a file and
// read through its real entry point, checked against its scene and validated (fuzz/fuzz_readers.cpp).

#include <cstddef>
#include <cstdint>

#include "fuzz/fuzz_readers.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, std::size_t size) {
  static const sahbench::fuzz::FuzzReader& reader = sahbench::fuzz::fuzz_reader("tree_file");
  sahbench::fuzz::read_or_refuse(reader, sahbench::fuzz::write_input(reader, data, size));
  return 0;
}
