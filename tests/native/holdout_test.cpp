// Holdout (Material::holdout, Cycles' object Mask > Holdout): camera rays that meet a holdout
// surface give no colour and alpha 0; every other ray sees the surface as it is. Which methods
// honour it each declares (Method::holdout); the declaration is checked against what it renders.
#include <gtest/gtest.h>

#include <algorithm>
#include <string>
#include <vector>

#include "render_for_tests.h"

namespace gp {
namespace {

// A grey floor under a white sky, seen from above (every camera ray hits something), and a grey
// card standing on it in the left half of the view, `card_keys` added to its material.
Scene card_scene(const std::string& card_keys) {
  return scene_from(R"({"camera": {"position": [0, -3, 2.5], "look_at": [0, 0, 0], "up": [0, 0, 1], "fov": 40,
                                   "width": 16, "height": 12},
    "materials": {"floor": {"type": "diffuse", "color": 0.5},
                  "card": {"type": "diffuse", "color": 0.6)" + card_keys + R"(}},
    "environment": {"color": 1, "strength": 1},
    "objects": [{"type": "quad", "center": [0, 0, 0], "u": [6, 0, 0], "v": [0, 6, 0], "material": "floor"},
                {"type": "quad", "center": [-0.6, -0.5, 0.5], "u": [0.5, 0, 0], "v": [0, 0, 0.5], "material": "card"}]})");
}

Params small_params(const Method& m, bool transparent) {
  Params p;
  p.set("seed", 5);
  p.set("threads", 1);
  if (m.find("photons")) p.set("photons", 3000);
  if (m.find("bins")) p.set("bins", 3);
  if (transparent) p.set("film_transparent", true);
  return p;
}

float luminance_at(const Film& f, int x, int y) { return f.rgb(pass::kCombined, x, y).luminance(); }

// The pixels the card covers wholly and those it does not touch, from pt's alpha with the card
// a holdout: 0 and 1 (a pixel the card's edge crosses has a fraction, and is in neither).
void card_pixels(std::vector<int>* held, std::vector<int>* clear) {
  const Scene s = card_scene(R"(, "holdout": true)");
  Params p = small_params(find_method("pt"), true);
  const Film f = render("pt", s, 16, p);
  const Pass& a = f.pass(pass::kAlpha);
  for (int i = 0; i < static_cast<int>(f.pixel_count()); ++i) {
    if (a.data[i] == 0.0f) held->push_back(i);
    if (a.data[i] == 1.0f) clear->push_back(i);
  }
}

TEST(Holdout, CameraRaysGiveNoColourAndAlphaZeroInTheMethodsThatDeclareIt) {
  std::vector<int> held, clear;
  card_pixels(&held, &clear);
  ASSERT_GE(held.size(), 6u);   // the card covers a block of pixels
  ASSERT_GE(clear.size(), 60u); // and leaves most of the floor
  const Scene holdout = card_scene(R"(, "holdout": true)");
  for (const Method& m : methods()) {
    for (bool transparent : {false, true}) {
      if (transparent && !m.find("film_transparent")) continue;
      const Film f = render(m.name, holdout, 2, small_params(m, transparent));
      double held_sum = 0, clear_sum = 0;
      for (int i : held) held_sum += luminance_at(f, i % f.width(), i / f.width());
      for (int i : clear) clear_sum += luminance_at(f, i % f.width(), i / f.width());
      const std::string what = m.name + (transparent ? ", transparent" : "");
      if (m.holdout) {
        EXPECT_EQ(held_sum, 0.0) << what << ": a holdout seen by the camera is black";
        if (transparent)
          for (int i : held) EXPECT_EQ(f.pass(pass::kAlpha).data[i], 0.0f) << what << " pixel " << i;
      } else {
        // It declares no holdout, so front ends warn: the card must then render as a card.
        EXPECT_GT(held_sum / held.size(), 0.05) << what << " renders a holdout it does not declare";
      }
      // (Two passes of few photons leave some floor pixels dark: the mean, not each pixel.)
      EXPECT_GT(clear_sum / clear.size(), 0.05) << what << ": the floor around the card renders";
    }
  }
}

// Only camera rays are held out: the floor beside the card, lit by a sky the card shadows and
// reflects to it, is bit for bit what it is with an ordinary card (pt: each pixel its own stream).
TEST(Holdout, OtherRaysSeeTheSurfaceAsItIs) {
  std::vector<int> held, clear;
  card_pixels(&held, &clear);
  const Film with = render("pt", card_scene(R"(, "holdout": true)"), 8, small_params(find_method("pt"), false));
  const Film without = render("pt", card_scene(""), 8, small_params(find_method("pt"), false));
  const Film gone = render("pt", card_scene(R"(, "holdout": true, "visible_to_camera": false)"), 8,
                           small_params(find_method("pt"), false));
  for (int i : clear) {
    const int x = i % with.width(), y = i / with.width();
    EXPECT_EQ(luminance_at(with, x, y), luminance_at(without, x, y)) << "pixel " << i;
  }
  // Hidden from the camera, a holdout is not met by camera rays at all: the floor shows there.
  double gone_held = 0;
  for (int i : held) gone_held += luminance_at(gone, i % gone.width(), i / gone.width());
  EXPECT_GT(gone_held / held.size(), 0.05);
}

// A holdout weighted by a mix (Cycles' Holdout closure in a Mix Shader; the exporter writes the
// mix with a black part and "holdout": its weight): camera rays go on to the surface, whose colour
// is its material's (the mix already scales it), and each covers its pixel by 1 - weight.
TEST(Holdout, AWeightedHoldoutCoversItsPixelsByOneMinusTheWeight) {
  std::vector<int> held, clear;
  card_pixels(&held, &clear);
  // The weight as a number, and as a link into the node graph (a Mix Shader's Fac from nodes).
  const Scene weighted = card_scene(R"(, "holdout": 0.7)");
  const Scene linked = card_scene(R"(, "holdout": {"link": "w", "output": "Value"},
      "nodes": {"w": {"type": "ShaderNodeMath", "props": {"operation": "MULTIPLY"},
                      "inputs": {"Value": 0.35, "Value_001": 2.0}}})");
  const Scene plain = card_scene("");
  for (const Method& m : methods()) {
    if (!m.holdout || !m.find("film_transparent")) continue;
    const Params p = small_params(m, true);
    const Film l = render(m.name, linked, 2, p);
    for (int i : held) EXPECT_NEAR(l.pass(pass::kAlpha).data[i], 0.3f, 1e-6f) << m.name << " (linked) pixel " << i;
    const Film f = render(m.name, weighted, 2, p);
    const Film g = render(m.name, plain, 2, p);
    for (int i : held) {
      EXPECT_NEAR(f.pass(pass::kAlpha).data[i], 0.3f, 1e-6f) << m.name << " pixel " << i;
      EXPECT_EQ(luminance_at(f, i % f.width(), i / f.width()), luminance_at(g, i % g.width(), i / g.width()))
          << m.name << ": the colour is the surface's, pixel " << i;
    }
    for (int i : clear) EXPECT_EQ(f.pass(pass::kAlpha).data[i], 1.0f) << m.name << " pixel " << i;
  }
}

// Cycles 3.4 gives held-out pixels alpha 0 with Film > Transparent off too, and the World it
// shows alpha 1 (measured in Blender: tests/blender/test_cycles_panels.py). So the methods that
// honour Holdout write alpha on a scene that holds out whatever the film (writes_alpha), and
// declare it (Method::passes_with with the scene); a scene without a holdout keeps no alpha.
TEST(Holdout, AnOpaqueFilmGetsAlphaZeroWhereHeldOutAndOneElsewhere) {
  std::vector<int> held, clear;
  card_pixels(&held, &clear);
  // The same view lifted: the top rows see the sky, which an opaque film covers.
  const std::string lifted = R"({"camera": {"position": [0, -3, 2.5], "look_at": [0, 0, 0.9], "up": [0, 0, 1],
      "fov": 40, "width": 16, "height": 12},
    "materials": {"floor": {"type": "diffuse", "color": 0.5}, "card": {"type": "diffuse", "color": 0.6, "holdout": true}},
    "environment": {"color": 1, "strength": 1},
    "objects": [{"type": "quad", "center": [0, 0, 0], "u": [6, 0, 0], "v": [0, 6, 0], "material": "floor"},
                {"type": "quad", "center": [-0.6, -0.5, 0.5], "u": [0.5, 0, 0], "v": [0, 0, 0.5], "material": "card"}]})";
  const Scene sky = scene_from(lifted), holdout = card_scene(R"(, "holdout": true)"), plain = card_scene("");
  ASSERT_TRUE(holdout.has_holdout() && sky.has_holdout() && card_scene(R"(, "holdout": 0.3)").has_holdout());
  ASSERT_FALSE(plain.has_holdout());
  for (const Method& m : methods()) {
    const Params p = small_params(m, false);
    const Film f = render(m.name, holdout, 2, p);
    EXPECT_EQ(f.has_pass(pass::kAlpha), m.holdout) << m.name;
    const std::vector<std::string> declared = m.passes_with(m.bind(p), &holdout);
    EXPECT_EQ(std::count(declared.begin(), declared.end(), pass::kAlpha), m.holdout ? 1 : 0) << m.name;
    EXPECT_FALSE(render(m.name, plain, 1, p).has_pass(pass::kAlpha)) << m.name << ": no holdout, no alpha";
    if (!m.holdout) continue;
    for (int i : held) EXPECT_EQ(f.pass(pass::kAlpha).data[i], 0.0f) << m.name << " pixel " << i;
    for (int i : clear) EXPECT_EQ(f.pass(pass::kAlpha).data[i], 1.0f) << m.name << " pixel " << i;
    const Film s = render(m.name, sky, 2, p);
    for (int x = 0; x < s.width(); ++x)  // the top row: sky
      EXPECT_EQ(s.pass(pass::kAlpha).data[x], 1.0f) << m.name << ": the World seen is covered, pixel " << x;
  }
}

TEST(Holdout, SceneFileKeyIsABooleanOrAWeight) {
  for (const char* bad : {R"(, "holdout": 1.5)", R"(, "holdout": -0.1)", R"(, "holdout": "yes")"}) {
    try {
      card_scene(bad);
      FAIL() << "accepted " << bad;
    } catch (const std::exception& e) {
      EXPECT_NE(std::string(e.what()).find("holdout"), std::string::npos) << e.what();
    }
  }
  const auto card = [](const Scene& s) {
    for (const Material& m : s.materials)
      if (m.name == "card") return m;
    ADD_FAILURE() << "no card";
    return Material{};
  };
  EXPECT_TRUE(card(card_scene(R"(, "holdout": 1)")).holdout);  // weight 1: the whole surface
  const Material quarter = card(card_scene(R"(, "holdout": 0.25)"));
  EXPECT_FALSE(quarter.holdout);
  EXPECT_EQ(quarter.holdout_weight, 0.25f);
}

}  // namespace
}  // namespace gp
