#include "solid/formats/asset.h"

#include <algorithm>

namespace solid::gltf {

Bounds ComputeBounds(const Asset& asset) {
  Bounds b;
  for (const Node& node : asset.nodes) {
    for (const Primitive& p : node.primitives) {
      for (size_t i = 0; i + 2 < p.positions.size(); i += 3) {
        for (int k = 0; k < 3; ++k) {
          double v = p.positions[i + static_cast<size_t>(k)];
          if (b.empty) {
            b.min[k] = b.max[k] = v;
          } else {
            b.min[k] = std::min(b.min[k], v);
            b.max[k] = std::max(b.max[k], v);
          }
        }
        b.empty = false;
      }
    }
  }
  return b;
}

uint64_t TriangleCount(const Asset& asset) {
  uint64_t n = 0;
  for (const Node& node : asset.nodes) {
    for (const Primitive& p : node.primitives) n += p.indices.size() / 3;
  }
  return n;
}

uint64_t VertexCount(const Asset& asset) {
  uint64_t n = 0;
  for (const Node& node : asset.nodes) {
    for (const Primitive& p : node.primitives) n += p.positions.size() / 3;
  }
  return n;
}

}  // namespace solid::gltf
