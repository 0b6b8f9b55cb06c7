#pragma once
// FNV-1a, 64-bit (Fowler, Noll and Vo): the one hash the project writes down, for run fingerprints, a
// tree file's scene identity and a file's contents. It tells inputs apart; it guards against no adversary.

#include <cstdint>
#include <string_view>

namespace sahbench {

inline constexpr uint64_t kFnv1aOffset = 0xcbf29ce484222325ull;
inline constexpr uint64_t kFnv1aPrime = 0x100000001b3ull;

/// `bytes` hashed on from `hash` (the offset basis to start), so that a stream is hashed in pieces.
inline uint64_t fnv1a(std::string_view bytes, uint64_t hash = kFnv1aOffset) {
  for (const char c : bytes) {
    hash ^= static_cast<unsigned char>(c);
    hash *= kFnv1aPrime;
  }
  return hash;
}

}  // namespace sahbench
