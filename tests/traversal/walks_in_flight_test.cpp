// step_interleaved: every ray answered once, by its own walk, in groups of neighbours stepped in turn;
// rays that start() answers itself skipped; counts that are not a multiple of the group.

#include "traversal/walks_in_flight.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstddef>
#include <optional>
#include <vector>

namespace sahbench {
namespace {

// A walk that takes `steps` steps and logs each one, so that a test can see the order of the steps.
struct CountingWalk {
  CountingWalk(std::size_t ray, std::size_t steps, std::vector<std::size_t>* log)
      : ray(ray), left(steps), log(log) {}
  bool step() {
    log->push_back(ray);
    return --left != 0;
  }
  std::size_t ray, left;
  std::vector<std::size_t>* log;
};

struct Outcome {
  std::vector<int> answered;          // per ray: how many times it was answered
  std::vector<std::size_t> steps;     // the ray of each step, in order
  std::vector<std::size_t> finished;  // the rays in the order their walks ended
};

// Rays [0, n); ray j's walk takes 1 + j % 5 steps, and rays with j % 7 == 3 are answered by start()
// after it made their walk.
template <std::size_t kWalks>
Outcome run(std::size_t n) {
  Outcome out;
  out.answered.assign(n, 0);
  detail::step_interleaved<CountingWalk, kWalks>(
      n,
      [&](std::optional<CountingWalk>& walk, std::size_t j) {
        EXPECT_FALSE(walk.has_value()) << "slot of ray " << j << " still holds a walk";
        walk.emplace(j, 1 + j % 5, &out.steps);
        if (j % 7 == 3) {
          // As the layouts do for a ray that misses the root: a walk was made, and the ray answered.
          ++out.answered[j];
          return false;
        }
        return true;
      },
      [&](std::size_t j, const CountingWalk& walk) {
        EXPECT_EQ(walk.ray, j);
        EXPECT_EQ(walk.left, 0u);
        ++out.answered[j];
        out.finished.push_back(j);
      });
  return out;
}

TEST(TravWalksInFlight, EveryRayIsAnsweredOnceByItsOwnWalk) {
  for (std::size_t n : {0u, 1u, 3u, 7u, 8u, 9u, 16u, 17u, 100u}) {
    const Outcome out = run<8>(n);
    for (std::size_t j = 0; j < n; ++j) EXPECT_EQ(out.answered[j], 1) << "ray " << j << " of " << n;
    std::size_t steps = 0;
    for (std::size_t j = 0; j < n; ++j)
      if (j % 7 != 3) steps += 1 + j % 5;
    EXPECT_EQ(out.steps.size(), steps) << n << " rays";
  }
}

TEST(TravWalksInFlight, NeighboursAreSteppedInTurnAndGroupsDoNotOverlap) {
  // Rays 0..9 less ray 3 (start() answers it): the first group is 0, 1, 2, 4, 5, 6, 7, 8; ray 9 starts
  // only after all of them ended.
  const Outcome out = run<8>(10);
  const std::vector<std::size_t> first_round = {0, 1, 2, 4, 5, 6, 7, 8};
  ASSERT_GE(out.steps.size(), first_round.size());
  EXPECT_EQ(std::vector<std::size_t>(out.steps.begin(), out.steps.begin() + 8), first_round);
  EXPECT_EQ(out.finished.back(), 9u);
  std::size_t first_of_9 = out.steps.size(), last_of_group = 0;
  for (std::size_t i = 0; i < out.steps.size(); ++i) {
    if (out.steps[i] == 9u)
      first_of_9 = std::min(first_of_9, i);
    else
      last_of_group = i;
  }
  EXPECT_GT(first_of_9, last_of_group) << "ray 9 stepped before the first group ended";
  EXPECT_EQ(out.steps.size() - first_of_9, 5u) << "ray 9's walk takes 1 + 9 % 5 steps";
}

TEST(TravWalksInFlight, OneWalkAtATimeIsTheRaysInOrder) {
  const Outcome out = run<1>(12);
  std::vector<std::size_t> expected;
  for (std::size_t j = 0; j < 12; ++j)
    if (j % 7 != 3) expected.push_back(j);
  EXPECT_EQ(out.finished, expected);
}

}  // namespace
}  // namespace sahbench
