// Embree's SAH builder (rtcBuildBVH) over triangles and over instances. The
// instances' tree is flattened depth-first into BvhNodes (a node's first child
// follows it); each mesh's binary tree (leaves of up to 3 triangles) is
// collapsed into a compressed 8-wide BVH (CwbvhNode), triangles in leaf order.
#include "backends/cuda/bvh_build.h"

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <cstring>
#include <stdexcept>
#include <string>

#include <embree3/rtcore.h>

#include "core/geometry.h"

namespace pn {
namespace {

// The builder's tree, in memory of its thread-local allocator (freed with the RTCBVH).
struct TmpNode {
  bool leaf = false;
  TmpNode* child[2] = {nullptr, nullptr};
  RTCBounds bounds[2];
  uint32_t count = 0;       // leaf: primitives
  const uint32_t* prims = nullptr;  // leaf: their IDs
};

void* create_node(RTCThreadLocalAllocator alloc, unsigned int children, void*) {
  if (children != 2) return nullptr;  // maxBranchingFactor is 2: the flattening reports it
  return new (rtcThreadLocalAlloc(alloc, sizeof(TmpNode), 16)) TmpNode();
}

void set_children(void* node, void** children, unsigned int count, void*) {
  for (unsigned i = 0; i < count && i < 2; ++i)
    static_cast<TmpNode*>(node)->child[i] = static_cast<TmpNode*>(children[i]);
}

void set_bounds(void* node, const RTCBounds** bounds, unsigned int count, void*) {
  for (unsigned i = 0; i < count && i < 2; ++i) static_cast<TmpNode*>(node)->bounds[i] = *bounds[i];
}

void* create_leaf(RTCThreadLocalAllocator alloc, const RTCBuildPrimitive* prims, size_t count, void*) {
  auto* n = new (rtcThreadLocalAlloc(alloc, sizeof(TmpNode), 16)) TmpNode();
  auto* ids = static_cast<uint32_t*>(rtcThreadLocalAlloc(alloc, sizeof(uint32_t) * count, 4));
  for (size_t i = 0; i < count; ++i) ids[i] = prims[i].primID;
  n->leaf = true;
  n->count = uint32_t(count);
  n->prims = ids;
  return n;
}

RTCBuildPrimitive build_primitive(Vec3 lo, Vec3 hi, uint32_t id) {
  RTCBuildPrimitive p;
  p.lower_x = lo.x, p.lower_y = lo.y, p.lower_z = lo.z;
  p.upper_x = hi.x, p.upper_y = hi.y, p.upper_z = hi.z;
  p.geomID = 0;
  p.primID = id;
  return p;
}

// Spatial splits (Stich, Friedrich & Dietrich, "Spatial Splits in Bounding
// Volume Hierarchies", HPG 2009): Embree's builder may cut a triangle's
// reference by an axis-aligned plane, and asks for the bounds of both parts.
// As Embree's own splitter: the triangle's vertices on each side and the
// points where its edges cross the plane, each side's box then clipped to the
// reference's current box (an earlier cut may have shrunk it). Both parts keep
// the triangle's ID; its leaves then hold copies of it.
void split_triangle(const RTCBuildPrimitive* prim, unsigned int dim, float pos, RTCBounds* left, RTCBounds* right,
                    void* user) {
  const TriangleMesh& m = *static_cast<const TriangleMesh*>(user);
  const auto& idx = m.indices[prim->primID];
  const Vec3 v[3] = {m.positions[idx[0]], m.positions[idx[1]], m.positions[idx[2]]};
  Vec3 llo(kInf), lhi(-kInf), rlo(kInf), rhi(-kInf);
  for (int i = 0; i < 3; ++i) {
    const Vec3 a = v[i], b = v[(i + 1) % 3];
    const float da = a[int(dim)], db = b[int(dim)];
    if (da <= pos) llo = vmin(llo, a), lhi = vmax(lhi, a);
    if (da >= pos) rlo = vmin(rlo, a), rhi = vmax(rhi, a);
    if ((da < pos && db > pos) || (da > pos && db < pos)) {
      Vec3 c = a + (b - a) * ((pos - da) / (db - da));
      c[int(dim)] = pos;
      llo = vmin(llo, c), lhi = vmax(lhi, c);
      rlo = vmin(rlo, c), rhi = vmax(rhi, c);
    }
  }
  const Vec3 plo(prim->lower_x, prim->lower_y, prim->lower_z), phi(prim->upper_x, prim->upper_y, prim->upper_z);
  llo = vmax(llo, plo), lhi = vmin(lhi, phi);
  rlo = vmax(rlo, plo), rhi = vmin(rhi, phi);
  lhi[int(dim)] = std::min(lhi[int(dim)], pos);
  rlo[int(dim)] = std::max(rlo[int(dim)], pos);
  *left = {llo.x, llo.y, llo.z, 0.f, lhi.x, lhi.y, lhi.z, 0.f};
  *right = {rlo.x, rlo.y, rlo.z, 0.f, rhi.x, rhi.y, rhi.z, 0.f};
}

void set_box(float* xy, float* z, const RTCBounds& b) {
  xy[0] = b.lower_x, xy[1] = b.upper_x, xy[2] = b.lower_y, xy[3] = b.upper_y;
  z[0] = b.lower_z, z[1] = b.upper_z;
}

class Builder {
 public:
  Builder() {
    device_ = rtcNewDevice(nullptr);
    if (!device_) throw std::runtime_error("cuda traversal: cannot create an Embree device for the BVH build");
  }
  ~Builder() { rtcReleaseDevice(device_); }

  // Builds a binary tree over `prims` (ids: what leaves hold) and hands its
  // root to `use`, which may read the tree until it returns. With `mesh`,
  // triangle references may be split (split_triangle), up to as many again as
  // there are triangles.
  template <class Use>
  void build(std::vector<RTCBuildPrimitive>& prims, uint32_t max_leaf, const TriangleMesh* mesh, const Use& use) {
    RTCBVH bvh = rtcNewBVH(device_);
    RTCBuildArguments a = rtcDefaultBuildArguments();
    const size_t count = prims.size();
    if (mesh) prims.resize(2 * count);  // room for the split references
    a.byteSize = sizeof(a);
    a.buildQuality = RTC_BUILD_QUALITY_HIGH;  // binned SAH, spatial splits where splitPrimitive is given
    a.maxBranchingFactor = 2;
    a.maxDepth = 48;
    a.minLeafSize = 1;
    a.maxLeafSize = max_leaf;
    a.traversalCost = 1.0f;
    a.intersectionCost = 1.0f;
    a.bvh = bvh;
    a.primitives = prims.data();
    a.primitiveCount = count;
    a.primitiveArrayCapacity = prims.size();
    a.createNode = create_node;
    a.setNodeChildren = set_children;
    a.setNodeBounds = set_bounds;
    a.createLeaf = create_leaf;
    if (mesh) {
      a.splitPrimitive = split_triangle;
      a.userPtr = const_cast<TriangleMesh*>(mesh);
    }
    auto* root = static_cast<TmpNode*>(rtcBuildBVH(&a));
    if (!root || rtcGetDeviceError(device_) != RTC_ERROR_NONE) {
      rtcReleaseBVH(bvh);
      throw std::runtime_error("cuda traversal: Embree's rtcBuildBVH failed (error " +
                               std::to_string(rtcGetDeviceError(device_)) + ")");
    }
    try {
      use(root);
    } catch (...) {
      rtcReleaseBVH(bvh);
      throw;
    }
    rtcReleaseBVH(bvh);
  }

 private:
  RTCDevice device_ = nullptr;
};

void check_node(const TmpNode* n, uint32_t max_leaf) {
  if (!n) throw std::runtime_error("cuda traversal: Embree's builder made a node that is not binary");
  if (n->leaf && (n->count == 0 || n->count > max_leaf)) throw std::runtime_error("cuda traversal: a leaf of bad size");
}

// A binary tree flattened depth-first into out.nodes (the top level); `leaf`
// returns a leaf's reference. Returns the root's reference; *depth: inner nodes
// on the longest path.
template <class Leaf>
int32_t flatten(const TmpNode* n, uint32_t max_leaf, BvhHost& out, uint32_t d, uint32_t* depth, const Leaf& leaf) {
  check_node(n, max_leaf);
  if (n->leaf) return leaf(n->prims, n->count);
  *depth = std::max(*depth, d + 1);
  const int32_t index = int32_t(out.nodes.size());
  out.nodes.emplace_back();
  BvhNode& node = out.nodes.back();
  set_box(node.c0, node.z, n->bounds[0]);
  set_box(node.c1, node.z + 2, n->bounds[1]);
  const int32_t c0 = flatten(n->child[0], max_leaf, out, d + 1, depth, leaf);
  const int32_t c1 = flatten(n->child[1], max_leaf, out, d + 1, depth, leaf);
  out.nodes[size_t(index)].child[0] = c0;  // `node` may have moved
  out.nodes[size_t(index)].child[1] = c1;
  return index;
}

// --- The compressed 8-wide BVH of a mesh (Ylitie, Karras & Laine 2017) --------------

struct WideChild {
  const TmpNode* node;
  RTCBounds box;
};

float half_area(const RTCBounds& b) {
  const float dx = b.upper_x - b.lower_x, dy = b.upper_y - b.lower_y, dz = b.upper_z - b.lower_z;
  return dx * dy + dy * dz + dz * dx;
}

// The children of the wide node made from binary node n: its two, then, while
// fewer than eight, the inner child of largest area opened into its two (the
// greedy collapse; Ylitie et al. choose by SAH over all ways, for a few
// percent).
std::vector<WideChild> wide_children(const TmpNode* n, uint32_t max_leaf) {
  std::vector<WideChild> c = {{n->child[0], n->bounds[0]}, {n->child[1], n->bounds[1]}};
  for (const WideChild& w : c) check_node(w.node, max_leaf);
  while (c.size() < 8) {
    int open = -1;
    float largest = -1.f;
    for (size_t i = 0; i < c.size(); ++i)
      if (!c[i].node->leaf && half_area(c[i].box) > largest) open = int(i), largest = half_area(c[i].box);
    if (open < 0) break;
    const TmpNode* o = c[size_t(open)].node;
    check_node(o->child[0], max_leaf);
    check_node(o->child[1], max_leaf);
    c[size_t(open)] = {o->child[0], o->bounds[0]};
    c.push_back({o->child[1], o->bounds[1]});
  }
  return c;
}

// Slot s gets the child that rays of octant s (direction negative in x, y, z
// where bits 4, 2, 1 of s are set) meet first: the smallest projection of its
// centre, from the node's, on that direction; greedily, cheapest pair first.
std::vector<int> wide_slots(const std::vector<WideChild>& c) {
  const size_t n = c.size();
  auto centre = [](const RTCBounds& b) {
    return Vec3(b.lower_x + b.upper_x, b.lower_y + b.upper_y, b.lower_z + b.upper_z) * 0.5f;
  };
  Vec3 mid(0.f);
  for (const WideChild& w : c) mid = mid + centre(w.box);
  mid = mid * (1.f / float(n));
  std::vector<std::pair<float, int>> cost;  // (cost, child * 8 + slot)
  for (size_t i = 0; i < n; ++i)
    for (int s = 0; s < 8; ++s) {
      const Vec3 d(s & 4 ? -1.f : 1.f, s & 2 ? -1.f : 1.f, s & 1 ? -1.f : 1.f);
      cost.emplace_back(dot(centre(c[i].box) - mid, d), int(i) * 8 + s);
    }
  std::sort(cost.begin(), cost.end());
  std::vector<int> slot(n, -1);
  bool taken[8] = {};
  for (const auto& [k, is] : cost) {
    const int i = is / 8, s = is % 8;
    if (slot[size_t(i)] < 0 && !taken[s]) slot[size_t(i)] = s, taken[s] = true;
  }
  return slot;
}

// Quantizes children boxes to node `w` (origin and exponents from `box`, their
// union), rounding outwards in double (exact: float coordinates, power-of-two
// steps).
void quantize(CwbvhNode& w, const RTCBounds& box, int slot, const RTCBounds& child) {
  const float lo[3] = {box.lower_x, box.lower_y, box.lower_z}, hi[3] = {box.upper_x, box.upper_y, box.upper_z};
  const float clo[3] = {child.lower_x, child.lower_y, child.lower_z};
  const float chi[3] = {child.upper_x, child.upper_y, child.upper_z};
  uint8_t* qlo[3] = {w.qlo_x, w.qlo_y, w.qlo_z};
  uint8_t* qhi[3] = {w.qhi_x, w.qhi_y, w.qhi_z};
  for (int a = 0; a < 3; ++a) {
    (void)hi;
    const double step = std::ldexp(1.0, int(w.e[a]) - 127);
    const double l = std::floor((double(clo[a]) - double(lo[a])) / step);
    const double h = std::ceil((double(chi[a]) - double(lo[a])) / step);
    qlo[a][slot] = uint8_t(std::clamp(l, 0.0, 255.0));
    qhi[a][slot] = uint8_t(std::clamp(h, 0.0, 255.0));
  }
}

// Writes wide node `index` from children `c` and, depth first, the nodes below
// it; `leaf(ids, count)` appends a leaf's triangles to out.triangles. *depth:
// wide nodes on the longest path.
template <class Leaf>
void emit_wide(const std::vector<WideChild>& c, uint32_t index, uint32_t max_leaf, BvhHost& out, uint32_t d,
               uint32_t* depth, const Leaf& leaf) {
  *depth = std::max(*depth, d + 1);
  RTCBounds box = c[0].box;
  for (const WideChild& w : c) {
    box.lower_x = std::min(box.lower_x, w.box.lower_x), box.upper_x = std::max(box.upper_x, w.box.upper_x);
    box.lower_y = std::min(box.lower_y, w.box.lower_y), box.upper_y = std::max(box.upper_y, w.box.upper_y);
    box.lower_z = std::min(box.lower_z, w.box.lower_z), box.upper_z = std::max(box.upper_z, w.box.upper_z);
  }
  CwbvhNode node{};
  node.p[0] = box.lower_x, node.p[1] = box.lower_y, node.p[2] = box.lower_z;
  const float extent[3] = {box.upper_x - box.lower_x, box.upper_y - box.lower_y, box.upper_z - box.lower_z};
  for (int a = 0; a < 3; ++a) {
    // The smallest step with 255 steps over the extent (upper - lower is rounded: check in double).
    const double ext = double(a == 0 ? box.upper_x : a == 1 ? box.upper_y : box.upper_z) - double(node.p[a]);
    int e = extent[a] > 0.f ? int(std::ceil(std::log2(double(extent[a]) / 255.0))) : -126;
    e = std::max(e, -126);
    while (std::ldexp(255.0, e) < ext) ++e;
    if (e > 127) throw std::runtime_error("cuda traversal: a mesh too large for the wide BVH's grid");
    node.e[a] = uint8_t(e + 127);
  }
  const std::vector<int> slot = wide_slots(c);
  std::vector<size_t> order(c.size());  // children in slot order
  for (size_t i = 0; i < c.size(); ++i) order[i] = i;
  std::sort(order.begin(), order.end(), [&](size_t a, size_t b) { return slot[a] < slot[b]; });
  uint32_t inner = 0;
  for (const WideChild& w : c) inner += w.node->leaf ? 0u : 1u;
  node.child_base = uint32_t(out.wide.size());
  out.wide.resize(out.wide.size() + inner);
  node.tri_base = uint32_t(out.triangles.size());
  std::vector<std::pair<size_t, uint32_t>> below;  // (child, its node index)
  for (size_t i : order) {
    const int s = slot[i];
    quantize(node, box, s, c[i].box);
    if (c[i].node->leaf) {
      const uint32_t offset = uint32_t(out.triangles.size()) - node.tri_base;
      const uint32_t k = c[i].node->count;
      leaf(c[i].node->prims, k);
      node.meta[s] = uint8_t((((1u << k) - 1u) << 5) | offset);
    } else {
      node.meta[s] = uint8_t((1u << 5) | (24u + uint32_t(s)));
      node.imask |= uint8_t(1u << s);
      below.emplace_back(i, node.child_base + uint32_t(below.size()));
    }
  }
  out.wide[index] = node;
  for (const auto& [i, at] : below) emit_wide(wide_children(c[i].node, max_leaf), at, max_leaf, out, d + 1, depth, leaf);
}

}  // namespace

// The knobs are for measurements: leaves of up to 3 references (the most a
// wide node's slot holds; the SAH decides) and spatial splits are the defaults.
BvhBuildOptions BvhBuildOptions::from_environment() {
  BvhBuildOptions o;
  if (const char* env = std::getenv("PENUMBRA_CUDA_LEAF")) {
    const int v = std::atoi(env);
    if (v >= 1 && v <= int(kCwbvhMaxLeaf)) o.leaf_size = uint32_t(v);
  }
  if (const char* env = std::getenv("PENUMBRA_CUDA_SPLITS")) o.spatial_splits = std::strcmp(env, "0") != 0;
  return o;
}

BvhView BvhHost::view() const {
  BvhView v;
  v.nodes = nodes.data();
  v.wide = wide.data();
  v.triangles = triangles.data();
  v.instances = instances.data();
  v.items = items.data();
  v.spheres = spheres.data();
  v.root = root;
  v.num_items = uint32_t(items.size());
  v.num_nodes = uint32_t(nodes.size());
  v.any_alpha_masked = any_alpha_masked;
  return v;
}

uint64_t BvhHost::bytes() const {
  return nodes.size() * sizeof(BvhNode) + wide.size() * sizeof(CwbvhNode) + triangles.size() * sizeof(BvhTriangle) +
         instances.size() * sizeof(BvhInstance) + items.size() * sizeof(uint32_t) + spheres.size() * sizeof(float);
}

BvhHost build_bvh(const Scene& scene, const BvhBuildOptions& options) {
  const auto t0 = std::chrono::steady_clock::now();
  BvhHost out;
  Builder builder;

  // ---- Bottom level: one BVH per placed, non-empty mesh ----
  std::vector<bool> placed(scene.meshes.size(), false);
  for (const Instance& inst : scene.instances) placed.at(inst.mesh) = true;
  std::vector<int32_t> mesh_root(scene.meshes.size(), 0);
  std::vector<bool> mesh_built(scene.meshes.size(), false);
  std::vector<RTCBounds> mesh_bounds(scene.meshes.size());
  size_t leaves = 0;
  if (options.leaf_size < 1 || options.leaf_size > kCwbvhMaxLeaf)
    throw std::runtime_error("cuda traversal: leaf size " + std::to_string(options.leaf_size) + " outside 1.." +
                             std::to_string(kCwbvhMaxLeaf));
  const uint32_t leaf_size = options.leaf_size;
  const bool splits = options.spatial_splits;
  for (size_t mi = 0; mi < scene.meshes.size(); ++mi) {
    const TriangleMesh& m = scene.meshes[mi];
    if (!placed[mi] || m.indices.empty()) continue;
    std::vector<RTCBuildPrimitive> prims(m.indices.size());
    Vec3 lo_all(kInf), hi_all(-kInf);
    for (size_t t = 0; t < m.indices.size(); ++t) {
      const Vec3 a = m.positions[m.indices[t][0]], b = m.positions[m.indices[t][1]], c = m.positions[m.indices[t][2]];
      const Vec3 lo = vmin(a, vmin(b, c)), hi = vmax(a, vmax(b, c));
      prims[t] = build_primitive(lo, hi, uint32_t(t));
      lo_all = vmin(lo_all, lo);
      hi_all = vmax(hi_all, hi);
    }
    mesh_bounds[mi] = {lo_all.x, lo_all.y, lo_all.z, 0.f, hi_all.x, hi_all.y, hi_all.z, 0.f};
    uint32_t depth = 0;
    const auto leaf = [&](const uint32_t* ids, uint32_t count) {
      if (out.triangles.size() + count > kMaxTriangleReferences)
        throw std::runtime_error(scene.source + ": the cuda traversal holds at most " +
                                 std::to_string(kMaxTriangleReferences) +
                                 " triangle references (meshes' triangles, some split in two or more)");
      for (uint32_t i = 0; i < count; ++i) {
        const auto& idx = m.indices[ids[i]];
        const Vec3 p0 = m.positions[idx[0]], p1 = m.positions[idx[1]], p2 = m.positions[idx[2]];
        BvhTriangle tri = {{p0.x, p0.y, p0.z}, ids[i], {p1.x, p1.y, p1.z, 0.f}, {p2.x, p2.y, p2.z, 0.f}};
        out.triangles.push_back(tri);
      }
      ++leaves;
    };
    builder.build(prims, leaf_size, splits ? &m : nullptr, [&](const TmpNode* root) {
      check_node(root, leaf_size);
      mesh_root[mi] = int32_t(out.wide.size());
      out.wide.emplace_back();
      const std::vector<WideChild> c =
          root->leaf ? std::vector<WideChild>{{root, mesh_bounds[mi]}} : wide_children(root, leaf_size);
      emit_wide(c, uint32_t(mesh_root[mi]), leaf_size, out, 0, &depth, leaf);
    });
    out.stats.mesh_triangles += m.indices.size();
    mesh_built[mi] = true;
    ++out.stats.meshes;
    out.stats.max_mesh_depth = std::max(out.stats.max_mesh_depth, depth);
  }
  out.stats.mean_leaf_size = leaves ? double(out.triangles.size()) / double(leaves) : 0.0;
  out.stats.triangle_references = out.triangles.size();

  // ---- Top level: instances (their mesh's box in world space) and spheres ----
  std::vector<RTCBuildPrimitive> prims;
  for (size_t ii = 0; ii < scene.instances.size(); ++ii) {
    const Instance& inst = scene.instances[ii];
    if (!mesh_built[inst.mesh]) continue;
    const RTCBounds& b = mesh_bounds[inst.mesh];
    Vec3 lo(kInf), hi(-kInf);
    for (int k = 0; k < 8; ++k) {
      const Vec3 p = inst.to_world.point(Vec3(k & 1 ? b.upper_x : b.lower_x, k & 2 ? b.upper_y : b.lower_y,
                                              k & 4 ? b.upper_z : b.lower_z));
      lo = vmin(lo, p);
      hi = vmax(hi, p);
    }
    // The corners are rounded once more by the transform: widen by a few ulps of their size.
    const Vec3 pad = (vmax(lo * -1.f, hi) * 1e-6f) + Vec3(1e-30f);
    lo = lo - pad;
    hi = hi + pad;
    BvhInstance bi;
    bi.to_object = inst.to_object;
    bi.root = mesh_root[inst.mesh];
    bi.instance = uint32_t(ii);
    bi.alpha_masked = scene.instance_alpha_masked(inst) ? 1u : 0u;
    out.any_alpha_masked = out.any_alpha_masked || bi.alpha_masked;
    prims.push_back(build_primitive(lo, hi, uint32_t(out.items.size())));
    out.items.push_back(uint32_t(out.instances.size()));
    out.instances.push_back(bi);
  }
  for (size_t si = 0; si < scene.spheres.size(); ++si) {
    const Sphere& s = scene.spheres[si];
    const float r = sphere_bounds_radius(s.radius);
    out.spheres.insert(out.spheres.end(), {s.center.x, s.center.y, s.center.z, s.radius});
    prims.push_back(build_primitive(s.center - Vec3(r), s.center + Vec3(r), uint32_t(out.items.size())));
    out.items.push_back(kBvhItemSphere | uint32_t(si));
  }
  if (out.items.size() > kMaxLeafFirst)
    throw std::runtime_error(scene.source + ": the cuda traversal holds at most " + std::to_string(kMaxLeafFirst) +
                             " instances and spheres");
  if (!prims.empty()) {
    // One item per leaf: the traversal enters an instance from its leaf.
    builder.build(prims, 1, nullptr, [&](const TmpNode* root) {
      out.root = flatten(root, 1, out, 0, &out.stats.top_depth,
                         [](const uint32_t* ids, uint32_t) { return bvh_leaf_ref(ids[0], 1); });
    });
  }
  // The wide traversal's stack takes at most two groups a level (a node's children left, its triangles put off).
  if (out.stats.top_depth > kBvhStackSize || 2 * out.stats.max_mesh_depth > kCwbvhStackSize)
    throw std::runtime_error(scene.source + ": the cuda traversal's BVH is " + std::to_string(out.stats.top_depth) +
                             " nodes deep over the instances and " + std::to_string(out.stats.max_mesh_depth) +
                             " in a mesh, more than its stacks of " + std::to_string(kBvhStackSize) + " and " +
                             std::to_string(kCwbvhStackSize / 2));
  out.stats.build_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  return out;
}

}  // namespace pn
