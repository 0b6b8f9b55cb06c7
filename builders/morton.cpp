#include "builders/morton.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>

#include "builders/radix_sort.h"

namespace sahbench {
namespace {

// Primitives per task in the per-primitive loops: a few microseconds of work. The results do not depend
// on it.
constexpr std::size_t kGrain = 1u << 14;

// Spreads the low 10 bits of v to every third bit (bit i to bit 3i), by shifting halves, quarters, ... of
// the bits apart and masking.
uint32_t spread10(uint32_t v) {
  v &= 0x3FFu;
  v = (v | (v << 16)) & 0x030000FFu;
  v = (v | (v << 8)) & 0x0300F00Fu;
  v = (v | (v << 4)) & 0x030C30C3u;
  v = (v | (v << 2)) & 0x09249249u;
  return v;
}

// The same for the low 21 bits of v.
uint64_t spread21(uint64_t v) {
  v &= 0x1FFFFFu;
  v = (v | (v << 32)) & 0x001F00000000FFFFull;
  v = (v | (v << 16)) & 0x001F0000FF0000FFull;
  v = (v | (v << 8)) & 0x100F00F00F00F00Full;
  v = (v | (v << 4)) & 0x10C30C30C30C30C3ull;
  v = (v | (v << 2)) & 0x1249249249249249ull;
  return v;
}

// Box centres in double: the sum of two floats near the top of the float range would overflow in float.
struct Centre {
  double x, y, z;
};

Centre centre_of(const Aabb& b) {
  return {0.5 * (double(b.min.x) + double(b.max.x)), 0.5 * (double(b.min.y) + double(b.max.y)),
          0.5 * (double(b.min.z) + double(b.max.z))};
}

struct CentreBounds {
  Centre lo{std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity(),
            std::numeric_limits<double>::infinity()};
  Centre hi{-std::numeric_limits<double>::infinity(), -std::numeric_limits<double>::infinity(),
            -std::numeric_limits<double>::infinity()};

  void add(const Centre& c) {
    lo = {std::min(lo.x, c.x), std::min(lo.y, c.y), std::min(lo.z, c.z)};
    hi = {std::max(hi.x, c.x), std::max(hi.y, c.y), std::max(hi.z, c.z)};
  }
  void merge(const CentreBounds& o) {
    add(o.lo);
    add(o.hi);
  }
};

// Maps a centre to its cell on the 2^bits grid of cubic cells over the centres' box.
class Grid {
 public:
  Grid(const CentreBounds& b, uint32_t bits) : lo_(b.lo), last_(double((1u << bits) - 1)) {
    const double extent = std::max({b.hi.x - b.lo.x, b.hi.y - b.lo.y, b.hi.z - b.lo.z});
    // All centres equal: every primitive in cell 0.
    scale_ = extent > 0.0 ? double(1u << bits) / extent : 0.0;
  }
  // (c - lo) * scale lies in [0, 2^bits]; the clamp takes the top edge into the last cell.
  uint32_t cell(double c, double lo) const {
    return static_cast<uint32_t>(std::min((c - lo) * scale_, last_));
  }
  uint32_t x(const Centre& c) const { return cell(c.x, lo_.x); }
  uint32_t y(const Centre& c) const { return cell(c.y, lo_.y); }
  uint32_t z(const Centre& c) const { return cell(c.z, lo_.z); }

 private:
  Centre lo_;
  double last_;
  double scale_;
};

template <class Code>
Code encode(const Grid& grid, const Centre& c) {
  if constexpr (sizeof(Code) == 4)
    return morton30(grid.x(c), grid.y(c), grid.z(c));
  else
    return morton63(grid.x(c), grid.y(c), grid.z(c));
}

}  // namespace

uint32_t morton30(uint32_t x, uint32_t y, uint32_t z) {
  return (spread10(x) << 2) | (spread10(y) << 1) | spread10(z);
}

uint64_t morton63(uint32_t x, uint32_t y, uint32_t z) {
  return (spread21(x) << 2) | (spread21(y) << 1) | spread21(z);
}

template <class Code>
MortonOrder<Code> sort_by_morton(std::span<const Aabb> bounds) {
  const std::size_t n = bounds.size();
  // Min and max are exact in any order, so the grid does not depend on how the reduction splits.
  const CentreBounds all = tbb::parallel_reduce(
      tbb::blocked_range<std::size_t>(0, n, kGrain), CentreBounds{},
      [&](const tbb::blocked_range<std::size_t>& r, CentreBounds acc) {
        const std::size_t end = r.end();
        for (std::size_t i = r.begin(); i < end; ++i) acc.add(centre_of(bounds[i]));
        return acc;
      },
      [](CentreBounds a, const CentreBounds& b) {
        a.merge(b);
        return a;
      });
  const Grid grid(all, kMortonBits<Code> / 3);

  MortonOrder<Code> order{HugePageArray<Code>(n), HugePageArray<uint32_t>(n)};
  // In blocks: the centres into arrays of each coordinate first, then the codes from them in a loop
  // over plain arrays, which the compiler vectorizes (it does not over the boxes' interleaved floats).
  Code* const codes = order.codes.data();
  uint32_t* const ids = order.ids.data();
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, kGrain), [&, codes, ids](const auto& r) {
    const Grid local = grid;
    constexpr std::size_t kBlock = 256;
    alignas(64) double x[kBlock], y[kBlock], z[kBlock];
    for (std::size_t first = r.begin(); first < r.end(); first += kBlock) {
      const std::size_t count = std::min(kBlock, r.end() - first);
      for (std::size_t k = 0; k < count; ++k) {
        const Centre c = centre_of(bounds[first + k]);
        x[k] = c.x;
        y[k] = c.y;
        z[k] = c.z;
      }
      Code* const out = codes + first;
      for (std::size_t k = 0; k < count; ++k) out[k] = encode<Code>(local, Centre{x[k], y[k], z[k]});
      for (std::size_t k = 0; k < count; ++k) ids[first + k] = static_cast<uint32_t>(first + k);
    }
  });
  HugePageArray<Code> code_scratch(n);
  HugePageArray<uint32_t> id_scratch(n);
  radix_sort_pairs(order.codes, order.ids, code_scratch, id_scratch, kMortonBits<Code>);
  return order;
}

template MortonOrder<uint32_t> sort_by_morton<uint32_t>(std::span<const Aabb>);
template MortonOrder<uint64_t> sort_by_morton<uint64_t>(std::span<const Aabb>);

}  // namespace sahbench
