// Fixed-depth queues: each drop policy, its counters, a worker thread draining it, no allocation per push/pop.
#include <gtest/gtest.h>

#include <thread>

#include "firmware_app/runtime/bounded_queue.h"
#include "tests/support/allocation_counter.h"

namespace qsg::runtime {
namespace {

struct Update {
  int first = 0;
  int last = 0;
  int merged = 0;
};
void collate(Update& queued, Update&& incoming) {
  queued.last = incoming.last;
  queued.merged += 1 + incoming.merged;
}

TEST(BoundedQueueTest, DropOldestKeepsTheFreshest) {
  BoundedQueue<int> q("frames");
  std::string error;
  ASSERT_TRUE(q.init(3, budgets::DropPolicy::kDropOldest, nullptr, &error)) << error;
  int dropped_sum = 0;
  q.set_on_drop([](void* user, int&& v) { *static_cast<int*>(user) += 1000 + v; }, &dropped_sum);
  for (int i = 0; i < 5; ++i) q.push(int{i});
  EXPECT_EQ(dropped_sum, 1000 + 0 + 1000 + 1) << "the two oldest were handed back";
  const QueueStats s = q.stats();
  EXPECT_EQ(s.dropped, 2u);
  EXPECT_EQ(s.high_water, 3u);
  int v = -1;
  for (int expected : {2, 3, 4}) {
    ASSERT_TRUE(q.try_pop(&v));
    EXPECT_EQ(v, expected);
  }
  EXPECT_FALSE(q.try_pop(&v));
}

TEST(BoundedQueueTest, DropNewestKeepsTheHistory) {
  BoundedQueue<int> q("history");
  std::string error;
  ASSERT_TRUE(q.init(2, budgets::DropPolicy::kDropNewest, nullptr, &error)) << error;
  EXPECT_TRUE(q.push(1));
  EXPECT_TRUE(q.push(2));
  EXPECT_FALSE(q.push(3));
  int v = 0;
  ASSERT_TRUE(q.try_pop(&v));
  EXPECT_EQ(v, 1);
  EXPECT_EQ(q.stats().dropped, 1u);
}

TEST(BoundedQueueTest, CollateMergesIntoTheNewestQueuedElement) {
  BoundedQueue<Update> q("frontend_to_backend");
  std::string error;
  EXPECT_FALSE(q.init(2, budgets::DropPolicy::kCollate, nullptr, &error));
  EXPECT_NE(error.find("merge function"), std::string::npos) << error;
  ASSERT_TRUE(q.init(2, budgets::DropPolicy::kCollate, collate, &error)) << error;
  for (int i = 0; i < 6; ++i) EXPECT_TRUE(q.push(Update{i, i, 0}));
  EXPECT_EQ(q.stats().collated, 4u);
  EXPECT_EQ(q.stats().dropped, 0u) << "collating loses nothing";
  Update u;
  ASSERT_TRUE(q.try_pop(&u));
  EXPECT_EQ(u.first, 0);
  ASSERT_TRUE(q.try_pop(&u));
  EXPECT_EQ(u.first, 1);
  EXPECT_EQ(u.last, 5);
  EXPECT_EQ(u.merged, 4);
}

TEST(BoundedQueueTest, AWorkerThreadDrainsItAndCloseWakesIt) {
  BoundedQueue<int> q("segmentation");
  std::string error;
  ASSERT_TRUE(q.init(1024, budgets::DropPolicy::kDropNewest, nullptr, &error)) << error;
  long sum = 0;
  std::thread worker([&] {
    int v = 0;
    for (;;) {
      if (q.pop_wait(&v, 1000000000)) sum += v;
      else if (q.stats().size == 0 && q.stats().pushed >= 1001) return;  // closed and drained
    }
  });
  for (int i = 1; i <= 1000; ++i) ASSERT_TRUE(q.push(int{i}));
  q.close();
  EXPECT_FALSE(q.push(1)) << "closed: refused";
  worker.join();
  EXPECT_EQ(sum, 500500);
}

TEST(BoundedQueueTest, PushAndPopDoNotAllocate) {
  BoundedQueue<Update> q("q");
  std::string error;
  ASSERT_TRUE(q.init(4, budgets::DropPolicy::kCollate, collate, &error)) << error;
  Update u;
  EXPECT_NO_ALLOCATIONS({
    for (int i = 0; i < 100; ++i) {
      q.push(Update{i, i, 0});
      if (i % 3 == 0) q.try_pop(&u);
    }
  });
  EXPECT_FALSE(q.init(0, budgets::DropPolicy::kDropOldest, nullptr, &error));
}

}  // namespace
}  // namespace qsg::runtime
