// Rays traced together give the answers of rays traced one by one: Embree streams
// (Accelerator::intersect_stream / occluded_stream), Scene::intersect_coherent, and the path
// tracer's paths started from a first hit traced that way. The renderers rely on it to keep
// images identical when they trace a tile's camera rays as packets.
#include <gtest/gtest.h>

#include <optional>
#include <string>
#include <vector>

#include "core/rng.h"
#include "integrators/methods.h"
#include "integrators/path_tracer.h"
#include "scene/accel.h"
#include "scene/loader.h"

namespace gp {
namespace {

// A floor, a sphere, and a lamp panel that camera rays and shadow rays pass through (its
// Embree filter functions are installed), lit by a point light.
Scene filtered_scene() {
  return load_scene_from_string(R"({
    "camera": {"position": [0, -3, 1.5], "look_at": [0, 0, 0.5], "up": [0, 0, 1], "fov": 50, "width": 16, "height": 16},
    "materials": {"grey": {"type": "diffuse", "color": 0.5},
                  "glass": {"type": "dielectric", "ior": 1.5},
                  "lamp": {"type": "dielectric", "ior": 1, "emission": 1, "strength": 1,
                           "visible_to_camera": false, "casts_shadow": false}},
    "lights": [{"type": "point", "position": [0, 0, 3], "intensity": 8}],
    "objects": [{"type": "quad", "center": [0, 0, 0], "u": [3, 0, 0], "v": [0, 3, 0], "material": "grey"},
                {"type": "sphere", "center": [0.3, 0.2, 0.5], "radius": 0.4, "segments": 24, "material": "glass"},
                {"type": "quad", "center": [0, 0, 1.2], "u": [0.8, 0, 0], "v": [0, 0.8, 0], "material": "lamp"}]})",
                                ".", "stream_test.json");
}

// Rays from random points of a box towards random points of the scene, in runs of camera and
// non-camera rays (a stream splits where the flag changes), some with a short tmax.
std::vector<Ray> random_rays(size_t n) {
  Rng rng(7, 3);
  std::vector<Ray> rays;
  for (size_t i = 0; i < n; ++i) {
    const Vec3 o(4 * rng.uniform() - 2, 4 * rng.uniform() - 2, 3 * rng.uniform() + 0.05f);
    const Vec3 target(2 * rng.uniform() - 1, 2 * rng.uniform() - 1, 1.5f * rng.uniform());
    Ray r(o, normalize(target - o), 0.0f, i % 5 == 0 ? 1.0f : kInfinity);
    r.camera = (i / 7) % 2 == 0;
    rays.push_back(r);
  }
  return rays;
}

TEST(RayStreams, StreamsAnswerAsSingleRays) {
  const Scene scene = filtered_scene();
  const Accelerator& accel = scene.accelerator();
  const std::vector<Ray> rays = random_rays(3000);
  std::vector<RawHit> hits(rays.size());
  std::unique_ptr<bool[]> found(new bool[rays.size()]), blocked(new bool[rays.size()]);
  accel.intersect_stream(rays.data(), rays.size(), hits.data(), found.get());
  accel.occluded_stream(rays.data(), rays.size(), blocked.get());
  int lamp_hits = 0, lamp_skipped = 0, misses = 0;
  const int lamp = static_cast<int>(scene.meshes.size()) - 1;
  for (size_t i = 0; i < rays.size(); ++i) {
    RawHit one;
    const bool f = accel.intersect(rays[i], one);
    ASSERT_EQ(found[i], f) << "ray " << i;
    EXPECT_EQ(blocked[i], accel.occluded(rays[i])) << "ray " << i;
    if (!f) {
      ++misses;
      continue;
    }
    EXPECT_EQ(hits[i].t, one.t) << "ray " << i;
    EXPECT_EQ(hits[i].u, one.u);
    EXPECT_EQ(hits[i].v, one.v);
    EXPECT_EQ(hits[i].geom, one.geom);
    EXPECT_EQ(hits[i].prim, one.prim);
    // The filter at work: non-camera rays stop at the lamp, camera rays go through it.
    if (one.geom == lamp) ++lamp_hits;
    if (rays[i].camera) {
      Ray plain = rays[i];
      plain.camera = false;
      RawHit p;
      if (accel.intersect(plain, p) && p.geom == lamp) ++lamp_skipped;
    }
  }
  EXPECT_GT(lamp_hits, 20);     // the test exercises the filter on both kinds of ray
  EXPECT_GT(lamp_skipped, 20);
  EXPECT_GT(misses, 20);
}

TEST(RayStreams, CoherentHitsAreTheSingleRayHits) {
  const Scene scene = filtered_scene();
  const std::vector<Ray> rays = random_rays(1000);
  std::vector<std::optional<SurfaceHit>> hits(rays.size());
  scene.intersect_coherent(rays.data(), rays.size(), hits.data());
  for (size_t i = 0; i < rays.size(); ++i) {
    const auto one = scene.intersect(rays[i]);
    ASSERT_EQ(hits[i].has_value(), one.has_value()) << "ray " << i;
    if (!one) continue;
    const SurfaceHit& a = *hits[i];
    const SurfaceHit& b = *one;
    EXPECT_EQ(a.t, b.t);
    for (int k = 0; k < 3; ++k) {
      EXPECT_EQ(a.p[k], b.p[k]);
      EXPECT_EQ(a.ng[k], b.ng[k]);
      EXPECT_EQ(a.ns[k], b.ns[k]);
    }
    EXPECT_EQ(a.uv.x, b.uv.x);
    EXPECT_EQ(a.uv.y, b.uv.y);
    EXPECT_EQ(a.mesh, b.mesh);
    EXPECT_EQ(a.prim, b.prim);
    EXPECT_EQ(a.material, b.material);
    EXPECT_EQ(a.light, b.light);
  }
}

TEST(RayStreams, PathFromATracedFirstHitIsThePathItself) {
  const Scene scene = load_scene(std::string(GRADPHOTON_SOURCE_DIR) + "/scenes/cornell-glass.json");
  Params params;
  params.set("threads", 1);
  PathTracer pt(scene, find_method("pt").bind(params));
  std::vector<PixelStart> starts;
  for (int k = 0; k < 64; ++k) starts.push_back(start_pixel(scene.camera, 5, 0, 3 * k % 97, 5 * k % 89));
  std::vector<Ray> camera(starts.size());
  std::vector<std::optional<SurfaceHit>> hits(starts.size());
  trace_camera_rays(scene, starts.data(), starts.size(), camera.data(), hits.data());
  int lit = 0;
  for (size_t k = 0; k < starts.size(); ++k) {
    Rng a = starts[k].rng, b = starts[k].rng;
    RayCounts ra, rb;
    const RGB given = pt.Li(camera[k], a, ra, nullptr, &hits[k]);
    const RGB traced = pt.Li(scene.camera.generate_ray(starts[k].film, starts[k].lens), b, rb);
    for (int c = 0; c < 3; ++c) EXPECT_EQ(given[c], traced[c]) << "path " << k;
    EXPECT_EQ(ra.closest, rb.closest);
    EXPECT_EQ(ra.shadow, rb.shadow);
    lit += traced.luminance() > 0;
  }
  EXPECT_GT(lit, 16);  // paths that carry light, so a wrong first hit would show
}

// Scene::intersect_point (GPM's shift and walk rays) is intersect() less the shading: the same
// place, normal, uv and triangle, bit for bit, so a method may trace either.
TEST(RayStreams, IntersectPointIsIntersectsHitWithoutShading) {
  const Scene scene = filtered_scene();
  int hits = 0;
  for (const Ray& ray : random_rays(2000)) {
    const auto full = scene.intersect(ray);
    const auto point = scene.intersect_point(ray);
    ASSERT_EQ(full.has_value(), point.has_value());
    if (!full) continue;
    ++hits;
    EXPECT_EQ(point->t, full->t);
    for (int k = 0; k < 3; ++k) {
      EXPECT_EQ(point->p[k], full->p[k]);
      EXPECT_EQ(point->ng[k], full->ng[k]);
    }
    EXPECT_EQ(point->uv.x, full->uv.x);
    EXPECT_EQ(point->uv.y, full->uv.y);
    EXPECT_EQ(point->mesh, full->mesh);
    EXPECT_EQ(point->prim, full->prim);
    EXPECT_EQ(point->material, full->material);
  }
  EXPECT_GT(hits, 500);
}

}  // namespace
}  // namespace gp
