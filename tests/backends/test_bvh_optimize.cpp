// The reinsertion optimization (backends/cuda/bvh_optimize.h) on trees made by hand: a bad tree reaches the best
// one, the cost never rises (over every node, and over the default share of the largest), and every leaf stays once
// with consistent parents and boxes that hold their children.
#include <gtest/gtest.h>

#include <algorithm>
#include <vector>

#include "backends/cuda/bvh_optimize.h"
#include "core/rng.h"

namespace pn {
namespace {

using Node = BuildTree::Node;

// A unit cube's leaf at x (one primitive: its index).
int32_t leaf(BuildTree& t, float x, float y = 0.f) {
  Node n;
  n.lo[0] = x, n.lo[1] = y, n.lo[2] = 0.f;
  n.hi[0] = x + 1.f, n.hi[1] = y + 1.f, n.hi[2] = 1.f;
  n.first = uint32_t(t.prims.size());
  n.count = 1;
  t.prims.push_back(uint32_t(t.nodes.size()));
  t.nodes.push_back(n);
  return int32_t(t.nodes.size() - 1);
}

int32_t join(BuildTree& t, int32_t a, int32_t b) {
  Node n;
  n.child[0] = a, n.child[1] = b;
  for (int k = 0; k < 3; ++k) {
    n.lo[k] = std::min(t.nodes[size_t(a)].lo[k], t.nodes[size_t(b)].lo[k]);
    n.hi[k] = std::max(t.nodes[size_t(a)].hi[k], t.nodes[size_t(b)].hi[k]);
  }
  t.nodes.push_back(n);
  const int32_t i = int32_t(t.nodes.size() - 1);
  t.nodes[size_t(a)].parent = t.nodes[size_t(b)].parent = i;
  return i;
}

// Every leaf reached once from the root, parents consistent, each inner box the union of its children's.
void check_tree(const BuildTree& t, size_t leaves) {
  std::vector<int> seen(t.nodes.size(), 0);
  std::vector<int32_t> stack = {t.root};
  ASSERT_EQ(t.nodes[size_t(t.root)].parent, -1);
  size_t found = 0;
  while (!stack.empty()) {
    const int32_t i = stack.back();
    stack.pop_back();
    ASSERT_EQ(seen[size_t(i)]++, 0) << "node " << i << " reached twice";
    const Node& n = t.nodes[size_t(i)];
    if (n.leaf()) {
      ++found;
      continue;
    }
    for (int c = 0; c < 2; ++c) {
      const Node& ch = t.nodes[size_t(n.child[c])];
      ASSERT_EQ(ch.parent, i);
      for (int k = 0; k < 3; ++k) EXPECT_TRUE(n.lo[k] <= ch.lo[k] && ch.hi[k] <= n.hi[k]);
      stack.push_back(n.child[c]);
    }
  }
  EXPECT_EQ(found, leaves);
  EXPECT_EQ(std::count(seen.begin(), seen.end(), 1), std::ptrdiff_t(t.nodes.size())) << "every node in the tree";
}

TEST(BvhReinsertion, PairsTheNearLeaves) {
  // Four cubes at x = 0, 1, 10, 11 paired badly ((0, 10), (1, 11)) under a root, with a fifth far away above the
  // root so that the pairs are not the root's children (those stay where they are).
  BuildTree t;
  const int32_t a = leaf(t, 0), b = leaf(t, 1), c = leaf(t, 10), d = leaf(t, 11), e = leaf(t, 0, 40);
  t.root = join(t, join(t, join(t, a, c), join(t, b, d)), e);
  const double before = t.inner_area_ratio();
  const ReinsertionStats s = optimize_by_reinsertion(t, 1.0);  // every node, as small trees need
  check_tree(t, 5);
  EXPECT_DOUBLE_EQ(s.cost_before, before);
  EXPECT_DOUBLE_EQ(s.cost_after, t.inner_area_ratio());
  // The best tree: ((0, 1), (10, 11)) beside the far cube, whose inner boxes are 2x1x1, 2x1x1, 12x1x1 and the root.
  BuildTree best;
  const int32_t a2 = leaf(best, 0), b2 = leaf(best, 1), c2 = leaf(best, 10), d2 = leaf(best, 11), e2 = leaf(best, 0, 40);
  best.root = join(best, join(best, join(best, a2, b2), join(best, c2, d2)), e2);
  EXPECT_NEAR(t.inner_area_ratio(), best.inner_area_ratio(), 1e-12);
  EXPECT_LT(s.cost_after, before);
  EXPECT_GE(s.reinserted, 1);
}

TEST(BvhReinsertion, NeverRaisesTheCostOfRandomTrees) {
  Rng rng(3, 0, 1);
  for (int trial = 0; trial < 20; ++trial) {
    BuildTree t;
    std::vector<int32_t> pool;
    const int n = 8 + trial * 13;
    for (int i = 0; i < n; ++i) pool.push_back(leaf(t, 100.f * rng.uniform(), 100.f * rng.uniform()));
    while (pool.size() > 1) {  // random pairs: a poor tree
      const size_t i = std::min(pool.size() - 1, size_t(rng.uniform() * float(pool.size())));
      const int32_t x = pool[i];
      pool.erase(pool.begin() + std::ptrdiff_t(i));
      const size_t j = std::min(pool.size() - 1, size_t(rng.uniform() * float(pool.size())));
      pool[j] = join(t, x, pool[j]);
    }
    t.root = pool[0];
    const double before = t.inner_area_ratio();
    BuildTree all = t;
    const ReinsertionStats s = optimize_by_reinsertion(t), s_all = optimize_by_reinsertion(all, 1.0);
    check_tree(t, size_t(n));
    check_tree(all, size_t(n));
    EXPECT_LE(s.cost_after, before * (1 + 1e-12)) << "trial " << trial;
    EXPECT_LE(s_all.cost_after, before * (1 + 1e-12)) << "trial " << trial;
    if (n >= 20) {
      EXPECT_LT(s.cost_after, 0.9 * before) << "a random tree of " << n << " leaves, trial " << trial;
      EXPECT_LT(s_all.cost_after, 0.9 * before) << "a random tree of " << n << " leaves, trial " << trial;
    }
  }
}

TEST(BvhReinsertion, LeavesSmallTreesAlone) {
  BuildTree t;
  t.root = join(t, join(t, leaf(t, 0), leaf(t, 5)), leaf(t, 1));
  const std::vector<Node> nodes = t.nodes;
  const ReinsertionStats s = optimize_by_reinsertion(t);
  EXPECT_EQ(s.reinserted, 0);
  EXPECT_EQ(t.nodes.size(), nodes.size());
}

}  // namespace
}  // namespace pn
