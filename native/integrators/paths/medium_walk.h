// What the camera-path loop (camera_path.h) needs of participating media besides the media
// themselves (media/medium.h): shadow rays that cross medium boundaries and report how far they
// went in each medium, and per-channel transmittance from those lengths.
#pragma once

#include "media/medium.h"
#include "scene/scene.h"

namespace gp {

// The shadow test of next-event estimation. Without media (stack null) it is Scene::occluded,
// unchanged. With media it follows the ray through surfaces that cast no shadow (light objects,
// volume boundaries), tracking the media it is in from the path's stack, and sums the length
// travelled in each medium; any other surface blocks it.
class ShadowTest {
 public:
  ShadowTest(const Scene& scene, const MediumStack* stack) : scene_(scene), stack_(stack) {}

  // The surface vertex the next shadow ray leaves from, when its material has an interior
  // medium: a shadow ray into the other side crosses that boundary first (rough glass of murky
  // water). ray_d: the direction the path arrived along.
  void at_surface(int mesh, int interior, const Vec3& ng, const Vec3& ray_d) {
    mesh_ = mesh;
    interior_ = interior;
    ng_ = ng;
    ray_d_ = ray_d;
  }
  void in_medium() { interior_ = -1; }

  // False when occluded. p: the vertex, ng: its geometric normal (null for a point in a medium:
  // no offset). `lengths` receives the distances travelled in each medium (with media).
  bool visible(const Vec3& p, const Vec3* ng, const LightSample& ls, MediumLengths* lengths) const;
  // Whether visible() tracks media (the scene has some): only then does it need `lengths`, which
  // callers then construct (a MediumLengths is about 1.2 KB: zeroing one per shadow ray cost a
  // still scene's path tracing 2 %).
  bool tracks_media() const { return stack_ != nullptr; }

 private:
  const Scene& scene_;
  const MediumStack* stack_;
  int mesh_ = -1, interior_ = -1;
  Vec3 ng_, ray_d_;
};

// exp(-sum_m sigma_t,m(c) d_m) per channel: exact Beer-Lambert through homogeneous segments;
// times, for each stretch through a grid medium, its ratio-tracking estimate (unbiased; its
// random numbers seeded by the stretch's ray, media/medium.h grid_transmittance).
template <class F>
ChannelValues transmittance(const MediumLengths& lengths, int channels, F&& channels_of) {
  ChannelValues tau{};
  for (int i = 0; i < lengths.n; ++i) {
    const MediumChannels& c = channels_of(lengths.medium[i]);
    for (int k = 0; k < channels; ++k)
      if (c.sigma_t[k] > 0) tau[k] += c.sigma_t[k] * lengths.length[i];  // sigma 0: nothing, even over infinity
  }
  ChannelValues T{};
  for (int k = 0; k < channels; ++k) T[k] = std::exp(-tau[k]);
  for (int i = 0; i < lengths.n_pieces; ++i) {
    const MediumLengths::Piece& p = lengths.pieces[i];
    const ChannelValues Tg =
        grid_transmittance(channels_of(p.medium), channels, p.o, p.d, 0.0f, p.t, ray_seed(p.o, p.d, 0x5ad0));
    for (int k = 0; k < channels; ++k) T[k] *= Tg[k];
  }
  return T;
}

}  // namespace gp
