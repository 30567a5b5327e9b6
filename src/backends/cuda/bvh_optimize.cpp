// Reinsertion (bvh_optimize.h): Bittner, Hapala & Havran 2013, on the builder's binary tree.
#include "backends/cuda/bvh_optimize.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <queue>
#include <utility>

namespace pn {
namespace {

using Node = BuildTree::Node;

double box_area(const float lo[3], const float hi[3]) {
  const double dx = std::max(0.f, hi[0] - lo[0]), dy = std::max(0.f, hi[1] - lo[1]), dz = std::max(0.f, hi[2] - lo[2]);
  return 2.0 * (dx * dy + dy * dz + dz * dx);
}

double area(const Node& n) { return box_area(n.lo, n.hi); }

double union_area(const Node& a, const Node& b) {
  float lo[3], hi[3];
  for (int k = 0; k < 3; ++k) lo[k] = std::min(a.lo[k], b.lo[k]), hi[k] = std::max(a.hi[k], b.hi[k]);
  return box_area(lo, hi);
}

class Reinserter {
 public:
  explicit Reinserter(BuildTree& t) : t_(t) {}

  // One sweep: the `share` of the nodes (but the root's children) with the largest boxes, largest first, each moved
  // where the tree's inner area falls most, or left where it is. Returns the subtrees moved.
  int sweep(double share) {
    std::vector<std::pair<double, int32_t>> order;
    for (int32_t i = 0; i < int32_t(t_.nodes.size()); ++i)
      if (movable(i)) order.emplace_back(area(at(i)), i);
    const size_t take = std::min(order.size(), size_t(std::ceil(share * double(order.size()))));
    std::partial_sort(order.begin(), order.begin() + std::ptrdiff_t(take), order.end(),
                      std::greater<std::pair<double, int32_t>>());
    int moved = 0;
    for (size_t k = 0; k < take; ++k)
      if (movable(order[k].second)) moved += try_move(order[k].second) ? 1 : 0;
    return moved;
  }

 private:
  Node& at(int32_t i) { return t_.nodes[size_t(i)]; }

  // A node whose parent is not the root: taking it out leaves a tree under the same root.
  bool movable(int32_t i) {
    const Node& n = at(i);
    return n.parent >= 0 && at(n.parent).parent >= 0;
  }

  // Refits the boxes from `i` up; returns how much their areas fell in all.
  double refit_up(int32_t i) {
    double fell = 0;
    while (i >= 0) {
      const double before = area(at(i));
      t_.fit(i);
      fell += before - area(at(i));
      i = at(i).parent;
    }
    return fell;
  }

  void replace_child(int32_t parent, int32_t from, int32_t to) {
    Node& p = at(parent);
    p.child[p.child[0] == from ? 0 : 1] = to;
  }

  // Where `x` (detached) adds the least area as the sibling of a node of the tree: the area of the node that would
  // join them, and what the node's ancestors would grow by. Branch and bound, cheapest induced growth first.
  // *added: that least area.
  int32_t best_sibling(int32_t x, double* added) {
    const Node& xn = at(x);
    const double ax = area(xn);
    using Entry = std::pair<double, int32_t>;  // (induced cost: the ancestors' growth, node)
    std::priority_queue<Entry, std::vector<Entry>, std::greater<Entry>> queue;
    queue.emplace(0.0, t_.root);
    double best_cost = std::numeric_limits<double>::infinity();
    int32_t best = t_.root;
    while (!queue.empty()) {
      const auto [induced, i] = queue.top();
      queue.pop();
      if (induced + ax >= best_cost) break;  // every node left costs at least its induced cost plus x's own area
      const Node& n = at(i);
      const double joined = union_area(n, xn);
      if (induced + joined < best_cost) best_cost = induced + joined, best = i;
      if (!n.leaf()) {
        const double below = induced + joined - area(n);  // n itself would grow to the joined box
        if (below + ax < best_cost) {
          queue.emplace(below, n.child[0]);
          queue.emplace(below, n.child[1]);
        }
      }
    }
    *added = best_cost;
    return best;
  }

  // `x` (detached) put back as the sibling of `s`, under `joint` (a detached node), as its child `slot`.
  void insert(int32_t x, int32_t joint, int32_t s, int slot) {
    const int32_t up = at(s).parent;
    Node& j = at(joint);
    j.child[1 - slot] = s;
    j.child[slot] = x;
    j.parent = up;
    at(s).parent = joint;
    at(x).parent = joint;
    if (up < 0) t_.root = joint;
    else replace_child(up, s, joint);
    refit_up(joint);
  }

  // `x` taken out with its parent (its sibling takes the parent's place) and put back where it adds the least area,
  // if that is less than its taking out saved; else where it was.
  bool try_move(int32_t x) {
    const int32_t p = at(x).parent, g = at(p).parent;
    const int slot = at(p).child[0] == x ? 0 : 1;
    const int32_t sibling = at(p).child[1 - slot];
    replace_child(g, p, sibling);
    at(sibling).parent = g;
    const double saved = area(at(p)) + refit_up(g);
    double added = 0;
    const int32_t s = best_sibling(x, &added);
    const bool better = added < saved * (1.0 - 1e-9) && s != sibling;
    if (better) insert(x, p, s, 1);
    else insert(x, p, sibling, slot);  // as it was
    return better;
  }

  BuildTree& t_;
};

}  // namespace

double BuildTree::inner_area_ratio() const {
  if (root < 0) return 0.0;
  const double root_area = area(nodes[size_t(root)]);
  if (!(root_area > 0.0)) return 0.0;
  double sum = 0;  // every node is in the tree: reinsertion reuses the nodes it takes out
  for (const Node& n : nodes)
    if (!n.leaf()) sum += area(n);
  return sum / root_area;
}

void BuildTree::fit(int32_t i) {
  Node& n = nodes[size_t(i)];
  const Node &a = nodes[size_t(n.child[0])], &b = nodes[size_t(n.child[1])];
  for (int k = 0; k < 3; ++k) n.lo[k] = std::min(a.lo[k], b.lo[k]), n.hi[k] = std::max(a.hi[k], b.hi[k]);
}

uint32_t BuildTree::depth() const {
  if (root < 0) return 0;
  uint32_t deepest = 0;
  std::vector<std::pair<int32_t, uint32_t>> stack = {{root, 0u}};
  while (!stack.empty()) {
    const auto [i, d] = stack.back();
    stack.pop_back();
    const Node& n = nodes[size_t(i)];
    if (n.leaf()) continue;
    deepest = std::max(deepest, d + 1);
    stack.emplace_back(n.child[0], d + 1);
    stack.emplace_back(n.child[1], d + 1);
  }
  return deepest;
}

ReinsertionStats optimize_by_reinsertion(BuildTree& tree, double share, int max_sweeps, int patience) {
  ReinsertionStats s;
  s.cost_before = s.cost_after = tree.inner_area_ratio();
  size_t inner = 0;
  for (const Node& n : tree.nodes) inner += n.leaf() ? 0 : 1;
  if (inner < 4) return s;
  // Inner boxes as the union of their children's (leaves keep the builder's): what every refit keeps them.
  {
    std::vector<int32_t> post;  // children before parents
    std::vector<int32_t> stack = {tree.root};
    while (!stack.empty()) {
      const int32_t i = stack.back();
      stack.pop_back();
      post.push_back(i);
      const Node& n = tree.nodes[size_t(i)];
      if (!n.leaf()) stack.push_back(n.child[0]), stack.push_back(n.child[1]);
    }
    for (auto it = post.rbegin(); it != post.rend(); ++it)
      if (!tree.nodes[size_t(*it)].leaf()) tree.fit(*it);
  }
  Reinserter r(tree);
  double cost = tree.inner_area_ratio();
  int stale = 0;
  for (int b = 0; b < max_sweeps && stale < patience; ++b) {
    s.reinserted += r.sweep(share);
    ++s.sweeps;
    const double next = tree.inner_area_ratio();
    stale = next < cost * (1.0 - 1e-3) ? 0 : stale + 1;
    cost = next;
  }
  const double best_cost = cost;
  s.cost_after = best_cost;
  return s;
}

}  // namespace pn
