"""The pybind11 module gradphoton._native as scripts and the Blender addon use it."""
import pathlib

import numpy as np
import pytest

from gradphoton import _native

ROOT = pathlib.Path(__file__).resolve().parents[2]
CORNELL = str(ROOT / "scenes" / "cornell-box.json")


def test_methods_and_pass_names_come_from_the_core():
    assert "pt" in _native.methods()
    assert _native.PASS_COMBINED == "combined"


def test_progressive_session_returns_finite_passes():
    scene = _native.load_scene(CORNELL)
    scene.width, scene.height = 40, 30
    session = _native.Session(scene, "pt", {"seed": 3, "threads": 2})
    session.iterate()
    session.run(passes=3)
    stats = session.stats
    assert stats["passes"] == 3
    assert stats["paths"] == 3 * 40 * 30
    passes = session.develop()
    img = passes["combined"]
    assert img.shape == (30, 40, 3) and img.dtype == np.float32
    assert np.isfinite(img).all()
    assert img.mean() > 0.01


def test_same_seed_same_image_from_python():
    scene = _native.load_scene(CORNELL)
    scene.width, scene.height = 16, 16
    a = _native.Session(scene, "pt", {"seed": 9, "threads": 1})
    b = _native.Session(scene, "pt", {"seed": 9, "threads": 2})
    a.run(passes=2)
    b.run(passes=2)
    np.testing.assert_array_equal(a.develop()["combined"], b.develop()["combined"])


@pytest.mark.parametrize("method", ["pt", "spt-hero"])
def test_a_pass_paused_at_a_tile_goes_on_to_the_same_image(method):
    """iterate(seconds): a tile-resumable pass (pt, spt, spt-hero) returns early with the pass
    open (Blender shows the image within a long pass); calls until the pass ends give the image
    bit for bit of uninterrupted passes, and in between every pixel reached is a finite mean."""
    scene = _native.load_scene(CORNELL)
    scene.width, scene.height = 64, 48
    params = {"seed": 5, "threads": 1, "tile_size": 8}
    whole = _native.Session(scene, method, params)
    whole.run(passes=2)
    paused = _native.Session(scene, method, params)
    calls = 0
    while paused.stats.get("passes", 0) < 2:
        paused.iterate(seconds=1e-9)  # pause at the first chance: one tile a call
        calls += 1
        if calls == 5:  # mid-pass: some pixels have their sample, the rest none yet
            mid = paused.develop()["combined"]
            assert np.isfinite(mid).all()
            reached = (mid > 0).any(axis=2)
            assert 0 < reached.sum() < 64 * 48
            assert paused.stats["passes"] == 0
        assert calls < 1000
    assert calls == 2 * 8 * 6  # one tile a call: 48 tiles a pass
    np.testing.assert_array_equal(paused.develop()["combined"], whole.develop()["combined"])
    # Gradient passes are one whole: they never pause (photon methods: the test below).
    gpt = _native.Session(scene, "gpt", {"seed": 5, "threads": 1})
    gpt.iterate(seconds=1e-9)
    assert gpt.stats["passes"] == 1


@pytest.mark.parametrize("method", ["sppm", "ppm", "gpm", "msppm"])
def test_a_photon_methods_first_pass_pauses_and_goes_on_to_the_same_image(method):
    """iterate(seconds): a photon method's first pass returns early between its camera-path
    tiles and between its stages (photons, gather), so Blender publishes images within it: the
    camera paths' own light at the tiles they reached (GPM: its gather paths', before any
    gradient; MSPPM: its first eye pass's path tracing, before the radii weigh it). Its later passes are one whole each (a pause there would show the same image), and
    the image is bit for bit that of whole passes."""
    scene = _native.load_scene(CORNELL)
    scene.width, scene.height = 64, 48
    params = {"seed": 5, "threads": 1, "tile_size": 8, "photons": 2000}
    whole = _native.Session(scene, method, params)
    whole.run(passes=2)
    paused = _native.Session(scene, method, params)
    calls, lit = 0, []
    while paused.stats.get("passes", 0) < 1:
        paused.iterate(seconds=1e-9)  # pause at the first chance: one eye tile a call
        calls += 1
        images = paused.develop()
        img = images["combined"]
        assert np.isfinite(img).all()
        assert set(whole.develop()) - set(images) <= {"albedo", "normal", "depth"}  # the method's passes throughout
        if paused.stats.get("passes", 0) == 0:
            lit.append(int((img > 0).any(axis=2).sum()))
        assert calls < 1000
    # 48 eye tiles, then a pause after the eye pass and one after the photons: 50 images (MSPPM
    # traces its first pass's camera paths twice, the first time for its radii: 98).
    assert calls == (2 if method == "msppm" else 1) * 8 * 6 + 2
    assert 0 < lit[4] < lit[40] < 64 * 48 or method == "ppm" and lit[4] <= lit[40]
    paused.iterate(seconds=1e-9)  # the second pass: whole
    assert paused.stats["passes"] == 2
    counts = lambda st: {k: v for k, v in st.items() if "seconds" not in k}  # noqa: E731
    assert counts(paused.stats) == counts(whole.stats)  # rays, paths, shift failures: a whole pass's
    for name, image in whole.develop().items():
        np.testing.assert_array_equal(paused.develop()[name], image, err_msg=name)


def test_a_metropolis_pass_pauses_with_every_splat_so_far_and_goes_on_to_the_same_image():
    """iterate(seconds): gdmlt's passes (62 s at 1920 x 1080) stop at a chain's cancel poll when
    asked, so Blender publishes images within them; develop() then shows every chain's splats so
    far, the open pass's too, over the whole film (Method.paused_pass_covers_image); the next
    call goes on with the same chains, so the passes and the image are bit for bit whole ones'.
    The bootstrap before them pauses between its blocks of samples too, its images those
    samples' plain Monte Carlo estimate over the whole film."""
    scene = _native.load_scene(CORNELL)
    scene.width, scene.height = 64, 48
    # 2 chains of 3072 mutations a pass: cancel polls before their 1024th, 2048th and 3072nd.
    params = {"seed": 5, "threads": 1, "chains": 2, "mutations": 2}
    assert _native.method_description("gdmlt")["paused_pass_covers_image"]
    assert not _native.method_description("pt")["paused_pass_covers_image"]
    whole = _native.Session(scene, "gdmlt", params)
    whole.run(passes=2)
    paused = _native.Session(scene, "gdmlt", params)
    calls, lit, boot_lit = 0, [], []
    while paused.stats.get("passes", 0) < 2:
        paused.iterate(seconds=1e-9)  # pause at the first chance
        calls += 1
        images = paused.develop()
        assert set(whole.develop()) - set(images) <= {"albedo", "normal", "depth"}  # (after a pass)
        assert all(np.isfinite(v).all() for v in images.values())
        if paused.stats["passes"] == 0:
            lit.append(int((images["sample_density"] > 0).sum()))
            if len(lit) <= 2:  # the bootstrap's: its samples so far, more pixels at each
                boot_lit.append(int((images["combined"] > 0).any(axis=2).sum()))
        assert calls < 100
    # The bootstrap first (3072 samples: blocks of 1024, one a call, the third call going on into
    # the pass); then per pass 1023 mutations a call (chain 0's polls, then chain 1's), the last
    # call the rest.
    assert calls == 2 * 7 + 2
    assert lit[0] == lit[1] == 0  # the bootstrap's images: no chain state yet
    assert 0 < boot_lit[0] < boot_lit[1]
    assert 0 < lit[2] < lit[3] < lit[5]  # the open pass's chain states, more at each image
    counts = lambda st: {k: v for k, v in st.items() if "seconds" not in k}  # noqa: E731
    assert counts(paused.stats) == counts(whole.stats)
    for name, image in whole.develop().items():
        np.testing.assert_array_equal(paused.develop()[name], image, err_msg=name)


def test_bad_input_raises_clear_errors(tmp_path):
    with pytest.raises(ValueError, match="missing.json"):
        _native.load_scene(str(tmp_path / "missing.json"))
    scene = _native.load_scene(CORNELL)
    with pytest.raises(ValueError, match="unknown method"):
        _native.Session(scene, "nope", {})
    session = _native.Session(scene, "pt", {"max_dpeth": 3})
    assert session.unused_params == ["max_dpeth"]
