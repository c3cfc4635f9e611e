// A light subpath's specular chain as photon tracing records it and the manifold walk shifts
// it (GPM §4.2): below the method families, so photon tracing (photon/) and the shifts (shift/)
// share it without depending on each other.
#pragma once

#include <array>

#include "core/math.h"

namespace gp {

// A specular or glossy vertex of a light subpath, enough to rebuild its local surface model.
inline constexpr int kMaxChainVertices = 6;
struct ChainVertex {
  Vec3 p, ng;  // position, geometric normal
  int mesh = -1, prim = -1;
  bool transmission = false;  // the lobe the path took here
};

// GPM §4.2 step 2: a photon whose previous vertex is specular or glossy remembers its light
// subpath back to the reconnection vertex y_b, the last diffuse vertex or the light vertex
// (y_b .. y_{s-1} = y_b, v[0] .. v[count-1]). From a distant light, y_b is the photon's point
// on the emission disk and `dir` its direction, which every shift of the chain keeps (the
// chain moves across the parallel beam). Chains longer than kMaxChainVertices are not recorded.
struct PhotonChain {
  Vec3 p, ng, ns;     // y_b; a light vertex has its normal in ng (zero for a point or distant light)
  Vec3 dir;           // distant light: the unit direction of its photons; zero otherwise
  Vec3 wo;            // surface y_b: unit world direction towards y_{b-1}
  int material = -1;  // surface y_b
  Vec2 uv;  // texture coordinate there (Scene::bsdf)
  int light = -1;     // y_b is a vertex on this light
  int count = 0;
  std::array<ChainVertex, kMaxChainVertices> v{};
};

}  // namespace gp
