// libFuzzer target: the glTF and GLB loader (scenes/gltf_loader.h) on the fuzzer's bytes, written to a file
// and read through its real entry point (fuzz/fuzz_readers.cpp).

#include <cstddef>
#include <cstdint>

#include "fuzz/fuzz_readers.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, std::size_t size) {
  static const sahbench::fuzz::FuzzReader& reader = sahbench::fuzz::fuzz_reader("gltf");
  sahbench::fuzz::read_or_refuse(reader, sahbench::fuzz::write_input(reader, data, size));
  return 0;
}
