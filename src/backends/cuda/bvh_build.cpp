// Embree's SAH builder (rtcBuildBVH) over triangles and over instances, its
// trees flattened depth-first into bvh_layout.h's arrays: a node's first child
// follows it, triangles lie in leaf order.
#include "backends/cuda/bvh_build.h"

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <cstring>
#include <stdexcept>
#include <string>

#include <embree3/rtcore.h>

#include "backends/cuda/bvh_optimize.h"
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

void set_box(float* xy, float* z, const BuildTree::Node& b) {
  xy[0] = b.lo[0], xy[1] = b.hi[0], xy[2] = b.lo[1], xy[3] = b.hi[1];
  z[0] = b.lo[2], z[1] = b.hi[2];
}

class Builder {
 public:
  Builder() {
    device_ = rtcNewDevice(nullptr);
    if (!device_) throw std::runtime_error("cuda traversal: cannot create an Embree device for the BVH build");
  }
  ~Builder() { rtcReleaseDevice(device_); }

  // Builds a tree over `prims` (ids: what leaves hold) and flattens it into
  // out.nodes; `leaf` appends a leaf's primitives and returns its reference.
  // With `mesh`, triangle references may be split (split_triangle), up to as
  // many again as there are triangles. Returns the root's reference; *depth:
  // inner nodes on the longest path.
  template <class Leaf>
  int32_t build(std::vector<RTCBuildPrimitive>& prims, uint32_t max_leaf, BvhHost& out, uint32_t* depth,
                const Leaf& leaf, bool reinsertion, const TriangleMesh* mesh = nullptr, float triangle_cost = 1.f) {
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
    a.intersectionCost = triangle_cost;
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
    BuildTree tree;
    try {
      add_node(root, nullptr, -1, max_leaf, tree);  // the builder's memory is freed with the RTCBVH
    } catch (...) {
      rtcReleaseBVH(bvh);
      throw;
    }
    rtcReleaseBVH(bvh);
    tree.root = 0;
    if (reinsertion && !tree.nodes[0].leaf()) {
      const auto t0 = std::chrono::steady_clock::now();
      const uint32_t built_depth = tree.depth();
      BuildTree built = tree;
      const ReinsertionStats r = optimize_by_reinsertion(tree);
      // A deeper tree than the traversal's stack allows for two levels is not worth its gain: the builder's stays.
      if (tree.depth() > std::max(built_depth, kBvhStackSize / 2)) tree = std::move(built);
      else out.stats.reinserted += uint64_t(r.reinserted);
      out.stats.reinsertion_ms += std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    }
    *depth = 0;
    return flatten(tree, tree.root, out, 0, depth, leaf);
  }

 private:
  // The builder's node `n` (its box `b`: the parent's bounds of it; none for the root) and its subtree, appended.
  static int32_t add_node(const TmpNode* n, const RTCBounds* b, int32_t parent, uint32_t max_leaf, BuildTree& t) {
    if (!n) throw std::runtime_error("cuda traversal: Embree's builder made a node that is not binary");
    const int32_t index = int32_t(t.nodes.size());
    t.nodes.emplace_back();
    if (b) {
      BuildTree::Node& node = t.nodes.back();
      node.lo[0] = b->lower_x, node.lo[1] = b->lower_y, node.lo[2] = b->lower_z;
      node.hi[0] = b->upper_x, node.hi[1] = b->upper_y, node.hi[2] = b->upper_z;
    }
    t.nodes.back().parent = parent;
    if (n->leaf) {
      if (n->count == 0 || n->count > max_leaf) throw std::runtime_error("cuda traversal: a leaf of bad size");
      t.nodes.back().first = uint32_t(t.prims.size());
      t.nodes.back().count = n->count;
      t.prims.insert(t.prims.end(), n->prims, n->prims + n->count);
      return index;
    }
    const int32_t c0 = add_node(n->child[0], &n->bounds[0], index, max_leaf, t);
    const int32_t c1 = add_node(n->child[1], &n->bounds[1], index, max_leaf, t);
    t.nodes[size_t(index)].child[0] = c0;
    t.nodes[size_t(index)].child[1] = c1;
    if (!b) t.fit(index);  // the root's box: its children's
    return index;
  }

  // Depth first, a node's first child right after it.
  template <class Leaf>
  static int32_t flatten(const BuildTree& t, int32_t i, BvhHost& out, uint32_t d, uint32_t* depth, const Leaf& leaf) {
    const BuildTree::Node& n = t.nodes[size_t(i)];
    if (n.leaf()) return leaf(t.prims.data() + n.first, n.count);
    *depth = std::max(*depth, d + 1);
    const int32_t index = int32_t(out.nodes.size());
    out.nodes.emplace_back();
    BvhNode& node = out.nodes.back();
    set_box(node.c0, node.z, t.nodes[size_t(n.child[0])]);
    set_box(node.c1, node.z + 2, t.nodes[size_t(n.child[1])]);
    const int32_t c0 = flatten(t, n.child[0], out, d + 1, depth, leaf);
    const int32_t c1 = flatten(t, n.child[1], out, d + 1, depth, leaf);
    out.nodes[size_t(index)].child[0] = c0;  // `node` may have moved
    out.nodes[size_t(index)].child[1] = c1;
    return index;
  }

  RTCDevice device_ = nullptr;
};

}  // namespace

static_assert(kMaxLeafSize == 16, "render/gpu_tuning.cpp's cuda_leaf accepts 1..16");

BvhView BvhHost::view() const {
  BvhView v;
  v.nodes = nodes.data();
  v.triangles = triangles.data();
  v.instances = instances.data();
  v.items = items.data();
  v.spheres = spheres.data();
  v.root = root;
  v.num_items = uint32_t(items.size());
  v.num_nodes = uint32_t(nodes.size());
  v.any_alpha_masked = any_alpha_masked;
  v.flat = !any_alpha_masked &&
           std::all_of(instances.begin(), instances.end(), [](const BvhInstance& i) { return i.identity != 0; });
  return v;
}

uint64_t BvhHost::bytes() const {
  return nodes.size() * sizeof(BvhNode) + triangles.size() * sizeof(BvhTriangle) +
         instances.size() * sizeof(BvhInstance) + items.size() * sizeof(uint32_t) + spheres.size() * sizeof(float);
}

namespace {

// A box's edge products (x y, y z, z x): its surface area is twice their sum, and a linear map M takes it to a
// parallelepiped of area 2 (|Mx x My| x y + |My x Mz| y z + |Mz x Mx| z x), x, y, z the unit axes.
struct EdgeProducts {
  double xy = 0, yz = 0, zx = 0;
  void add(const float* xy_lo_hi, float zlo, float zhi) {
    const double dx = std::max(0.f, xy_lo_hi[1] - xy_lo_hi[0]), dy = std::max(0.f, xy_lo_hi[3] - xy_lo_hi[2]),
                 dz = std::max(0.f, zhi - zlo);
    xy += dx * dy, yz += dy * dz, zx += dz * dx;
  }
  double area(const EdgeProducts& k) const { return 2.0 * (k.xy * xy + k.yz * yz + k.zx * zx); }
};
constexpr EdgeProducts kIdentityFaces{1.0, 1.0, 1.0};

// An instance's face factors (|Mx x My|, |My x Mz|, |Mz x Mx|) for the linear part M of its to_world.
EdgeProducts face_factors(const Affine& to_world) {
  const float* m = to_world.m;  // rows (r0 r1 r2 t): column a is (m[a], m[4 + a], m[8 + a])
  auto col = [&](int a) { return Vec3(m[a], m[4 + a], m[8 + a]); };
  return EdgeProducts{double(length(cross(col(0), col(1)))), double(length(cross(col(1), col(2)))),
                      double(length(cross(col(2), col(0))))};
}

void root_box(const BvhNode& n, float xy[4], float* zlo, float* zhi) {
  xy[0] = std::min(n.c0[0], n.c1[0]), xy[1] = std::max(n.c0[1], n.c1[1]);
  xy[2] = std::min(n.c0[2], n.c1[2]), xy[3] = std::max(n.c0[3], n.c1[3]);
  *zlo = std::min(n.z[0], n.z[2]), *zhi = std::max(n.z[1], n.z[3]);
}

// The children's boxes of the inner nodes under `ref`, in their own space (one level: a top-level leaf stops it).
void subtree_boxes(const BvhHost& b, int32_t ref, EdgeProducts* sum) {
  if (ref < 0) return;
  const BvhNode& n = b.nodes[size_t(ref)];
  sum->add(n.c0, n.z[0], n.z[1]);
  sum->add(n.c1, n.z[2], n.z[3]);
  subtree_boxes(b, n.child[0], sum);
  subtree_boxes(b, n.child[1], sum);
}

// The world-space area of the children's boxes under top-level `ref`, each instance's mesh tree (its sums kept by
// mesh root in `mesh`) taken through its transform (`faces`: face_factors of each BvhInstance).
double top_areas(const BvhHost& b, int32_t ref, const std::vector<EdgeProducts>& faces,
                 std::vector<EdgeProducts>& mesh, std::vector<bool>& mesh_done) {
  if (ref < 0) {
    const uint32_t item = b.items[bvh_leaf_first(ref)];
    if (item & kBvhItemSphere) return 0.0;
    const int32_t root = b.instances[item].root;
    if (root < 0) return 0.0;  // a mesh of one leaf
    if (!mesh_done[size_t(root)]) subtree_boxes(b, root, &mesh[size_t(root)]), mesh_done[size_t(root)] = true;
    return mesh[size_t(root)].area(faces[item]);
  }
  const BvhNode& n = b.nodes[size_t(ref)];
  EdgeProducts own;
  own.add(n.c0, n.z[0], n.z[1]);
  own.add(n.c1, n.z[2], n.z[3]);
  return own.area(kIdentityFaces) + top_areas(b, n.child[0], faces, mesh, mesh_done) +
         top_areas(b, n.child[1], faces, mesh, mesh_done);
}

double sah_visits_per_ray(const BvhHost& b, const std::vector<EdgeProducts>& faces) {
  if (b.items.empty()) return 0.0;
  std::vector<EdgeProducts> mesh(b.nodes.size());
  std::vector<bool> mesh_done(b.nodes.size(), false);
  // The top level's root box: its children's union, or, where the root is one item's leaf, that item's mesh box
  // in world space.
  int32_t top = b.root;
  EdgeProducts root_faces = kIdentityFaces;
  if (top < 0) {
    const uint32_t item = b.items[bvh_leaf_first(top)];
    if ((item & kBvhItemSphere) || b.instances[item].root < 0) return 0.0;
    top = b.instances[item].root;
    root_faces = faces[item];
  }
  float xy[4], zlo, zhi;
  root_box(b.nodes[size_t(top)], xy, &zlo, &zhi);
  EdgeProducts root;
  root.add(xy, zlo, zhi);
  const double area = root.area(root_faces);
  return area > 0.0 ? top_areas(b, b.root, faces, mesh, mesh_done) / area : 0.0;
}

// The top level over `out`'s mesh trees (bottom_nodes, mesh_root, mesh_built, mesh_bounds): instances and spheres.
void build_top_level(const Scene& scene, BvhHost& out, Builder& builder);

}  // namespace

BvhHost build_bvh(const Scene& scene, const BvhBuildOptions& options) {
  const auto t0 = std::chrono::steady_clock::now();
  BvhHost out;
  out.options = options;
  Builder builder;

  // ---- Bottom level: one BVH per placed, non-empty mesh ----
  std::vector<bool> placed(scene.meshes.size(), false);
  for (const Instance& inst : scene.instances) placed.at(inst.mesh) = true;
  std::vector<int32_t> mesh_root(scene.meshes.size(), 0);
  std::vector<bool> mesh_built(scene.meshes.size(), false);
  std::vector<RTCBounds> mesh_bounds(scene.meshes.size());
  size_t leaves = 0;
  if (options.leaf_size < 1 || options.leaf_size > kMaxLeafSize)
    throw std::runtime_error("cuda traversal: leaf size " + std::to_string(options.leaf_size) + " outside 1.." +
                             std::to_string(kMaxLeafSize));
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
    mesh_root[mi] = builder.build(prims, leaf_size, out, &depth, [&](const uint32_t* ids, uint32_t count) {
      if (out.triangles.size() + count > kMaxLeafFirst)
        throw std::runtime_error(scene.source + ": the cuda traversal holds at most " + std::to_string(kMaxLeafFirst) +
                                 " triangle references (meshes' triangles, some split in two or more)");
      const uint32_t first = uint32_t(out.triangles.size());
      for (uint32_t i = 0; i < count; ++i) {
        const auto& idx = m.indices[ids[i]];
        const Vec3 p0 = m.positions[idx[0]], p1 = m.positions[idx[1]], p2 = m.positions[idx[2]];
        BvhTriangle tri = {{p0.x, p0.y, p0.z}, ids[i], {p1.x, p1.y, p1.z, 0.f}, {p2.x, p2.y, p2.z, 0.f}};
        out.triangles.push_back(tri);
      }
      ++leaves;
      return bvh_leaf_ref(first, count);
    }, options.reinsertion, splits ? &m : nullptr, options.triangle_cost);
    out.stats.mesh_triangles += m.indices.size();
    mesh_built[mi] = true;
    ++out.stats.meshes;
    out.stats.max_mesh_depth = std::max(out.stats.max_mesh_depth, depth);
  }
  out.stats.mean_leaf_size = leaves ? double(out.triangles.size()) / double(leaves) : 0.0;
  out.stats.triangle_references = out.triangles.size();
  out.bottom_nodes = out.nodes.size();
  out.mesh_root = std::move(mesh_root);
  out.mesh_built = std::move(mesh_built);
  out.mesh_bounds.resize(scene.meshes.size());
  for (size_t mi = 0; mi < scene.meshes.size(); ++mi) {
    const RTCBounds& b = mesh_bounds[mi];
    out.mesh_bounds[mi] = {Vec3(b.lower_x, b.lower_y, b.lower_z), Vec3(b.upper_x, b.upper_y, b.upper_z)};
  }
  build_top_level(scene, out, builder);
  out.stats.build_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  return out;
}

void rebuild_bvh_top(const Scene& scene, BvhHost& bvh) {
  if (bvh.mesh_root.size() != scene.meshes.size() || bvh.bottom_nodes > bvh.nodes.size())
    throw std::logic_error("rebuild_bvh_top: a BVH of another scene");
  Builder builder;
  build_top_level(scene, bvh, builder);
}

namespace {

void build_top_level(const Scene& scene, BvhHost& out, Builder& builder) {
  const std::vector<int32_t>& mesh_root = out.mesh_root;
  const std::vector<bool>& mesh_built = out.mesh_built;
  out.nodes.resize(out.bottom_nodes);
  out.instances.clear();
  out.items.clear();
  out.spheres.clear();
  out.root = 0;
  out.any_alpha_masked = false;
  out.stats.top_depth = 0;

  // ---- Top level: instances (their mesh's box in world space) and spheres ----
  std::vector<RTCBuildPrimitive> prims;
  std::vector<EdgeProducts> faces;  // per BvhInstance, for stats.sah_visits_per_ray
  for (size_t ii = 0; ii < scene.instances.size(); ++ii) {
    const Instance& inst = scene.instances[ii];
    if (!mesh_built[inst.mesh]) continue;
    const BvhHost::MeshBox& b = out.mesh_bounds[inst.mesh];
    Vec3 lo(kInf), hi(-kInf);
    for (int k = 0; k < 8; ++k) {
      const Vec3 p = inst.to_world.point(Vec3(k & 1 ? b.hi.x : b.lo.x, k & 2 ? b.hi.y : b.lo.y,
                                              k & 4 ? b.hi.z : b.lo.z));
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
    bi.identity = bi.to_object.is_identity() ? 1u : 0u;
    out.any_alpha_masked = out.any_alpha_masked || bi.alpha_masked;
    prims.push_back(build_primitive(lo, hi, uint32_t(out.items.size())));
    out.items.push_back(uint32_t(out.instances.size()));
    out.instances.push_back(bi);
    faces.push_back(face_factors(inst.to_world));
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
    out.root = builder.build(prims, 1, out, &out.stats.top_depth, [&](const uint32_t* ids, uint32_t count) {
      (void)count;
      return bvh_leaf_ref(ids[0], 1);
    }, out.options.reinsertion);
  }
  if (out.stats.top_depth + out.stats.max_mesh_depth > kBvhStackSize)
    throw std::runtime_error(scene.source + ": the cuda traversal's BVH is " +
                             std::to_string(out.stats.top_depth + out.stats.max_mesh_depth) +
                             " nodes deep, more than its stack of " + std::to_string(kBvhStackSize));
  out.stats.sah_visits_per_ray = sah_visits_per_ray(out, faces);
}

}  // namespace

}  // namespace pn
