#include "dco/pipeline/row_team.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <stdexcept>
#include <thread>
#include <vector>

#include "../support/allocation_counter.hpp"
#include "../support/thread_names.hpp"
#include "dco/core/error.hpp"
#include "dco/core/usable_cpus.hpp"

namespace dco::pipeline {
namespace {

TEST(RowTeam, HelpersCarryTheirName) {
  const long before = dco::testing::count_named(dco::testing::thread_names(), "dco-rows");
  {
    RowTeam team(3);
    // Each helper names itself as it starts; a run needs every helper, so it has started.
    team.run(30, [](int, int, int) {});
    EXPECT_EQ(dco::testing::count_named(dco::testing::thread_names(), "dco-rows"), before + 2);
  }
}

// Every row is visited exactly once, in contiguous blocks given by block_begin, each by the part
// it names; run after run on the same team.
TEST(RowTeam, EveryRowOnceInTheBlocksOfItsParts) {
  for (int threads : {1, 2, 3, 4}) {
    RowTeam team(threads);
    EXPECT_EQ(team.threads(), threads);
    for (int rows : {0, 1, 2, 3, 5, 17, 720}) {
      std::vector<std::atomic<int>> visits(static_cast<std::size_t>(rows));
      std::vector<std::atomic<int>> part_of(static_cast<std::size_t>(rows));
      team.run(rows, [&](int part, int begin, int end) {
        for (int y = begin; y < end; ++y) {
          visits[static_cast<std::size_t>(y)].fetch_add(1);
          part_of[static_cast<std::size_t>(y)].store(part);
        }
      });
      for (int y = 0; y < rows; ++y) {
        ASSERT_EQ(visits[static_cast<std::size_t>(y)].load(), 1) << threads << " " << rows;
        if (rows >= threads) {
          const int part = part_of[static_cast<std::size_t>(y)].load();
          EXPECT_GE(y, RowTeam::block_begin(rows, part, threads));
          EXPECT_LT(y, RowTeam::block_begin(rows, part + 1, threads));
        }
      }
    }
  }
}

// Part 0 is the caller's; the others run on threads of their own, the same ones every run.
TEST(RowTeam, PartZeroRunsOnTheCallerAndTheRestOnHelpers) {
  RowTeam team(3);
  std::vector<std::thread::id> first(3), again(3);
  team.run(30, [&](int part, int, int) {
    first[static_cast<std::size_t>(part)] = std::this_thread::get_id();
  });
  team.run(30, [&](int part, int, int) {
    again[static_cast<std::size_t>(part)] = std::this_thread::get_id();
  });
  EXPECT_EQ(first[0], std::this_thread::get_id());
  EXPECT_NE(first[1], first[0]);
  EXPECT_NE(first[2], first[0]);
  EXPECT_NE(first[1], first[2]);
  EXPECT_EQ(first, again);
}

// An error in any part reaches the caller once every part has returned, and the team goes on.
TEST(RowTeam, AnErrorReachesTheCallerAfterEveryPartAndTheTeamGoesOn) {
  RowTeam team(3);
  for (int failing : {0, 1, 2}) {
    std::atomic<int> finished{0};
    EXPECT_THROW(team.run(90,
                          [&](int part, int, int) {
                            if (part == failing) throw std::runtime_error("row failed");
                            std::this_thread::sleep_for(std::chrono::milliseconds(5));
                            finished.fetch_add(1);
                          }),
                 std::runtime_error);
    EXPECT_EQ(finished.load(), 2) << "part " << failing;
    std::atomic<int> rows{0};
    team.run(90, [&](int, int begin, int end) { rows.fetch_add(end - begin); });
    EXPECT_EQ(rows.load(), 90);
  }
}

// A frame's runs allocate nothing: the helpers are started once.
TEST(RowTeam, RunsAllocateNothing) {
  RowTeam team(4);
  std::vector<int> out(720, 0);
  const auto body = [&](int, int begin, int end) {
    for (int y = begin; y < end; ++y) out[static_cast<std::size_t>(y)] += y;
  };
  team.run(720, body);
  testing::start_counting_allocations();
  for (int i = 0; i < 100; ++i) team.run(720, body);
  EXPECT_EQ(testing::stop_counting_allocations().total(), 0);
  EXPECT_EQ(out[719], 101 * 719);
}

// A stage's row_threads: itself when set; auto leaves two CPUs to the two stage threads alone,
// and from four on takes half of them, at most four.
TEST(RowTeam, AutoTakesHalfTheUsableCpusFromFourOn) {
  EXPECT_EQ(RowTeam::threads_for(3), 3);
  EXPECT_EQ(RowTeam::threads_for(1), 1);
  const int cpus = usable_cpus();
  EXPECT_EQ(RowTeam::threads_for(0), cpus < 4 ? 1 : std::min(4, cpus / 2));
}

TEST(RowTeam, StopsWhenDestroyedAndRefusesBadSizes) {
  { RowTeam idle(4); }
  {
    RowTeam used(2);
    used.run(10, [](int, int, int) {});
  }
  EXPECT_THROW(RowTeam(0), Error);
  EXPECT_THROW(RowTeam(65), Error);
}

}  // namespace
}  // namespace dco::pipeline
