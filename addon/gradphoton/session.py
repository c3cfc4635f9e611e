"""One render: export, then a progressive loop on the native Session with Blender's progress,
stats, cancellation and passes. engine.py delegates here; nothing here is a Blender class.

Cancellation: each pass runs in a worker thread (the native call releases the GIL); the render
thread polls test_break() every 20 ms and calls Session.cancel(), which stops the pass between
tiles; the image so far is kept and returned.

Persistent Data (Render > Performance, as Cycles'): Blender keeps the engine between frames and
the native scene stays with it (PersistentScene); each frame syncs what changed (sync.py: moved
objects are transformed natively, unchanged meshes are not exported again).

Border: the camera's crop window (export/camera.py), so only the border's pixels are traced.

Motion blur: the export samples the scene over the shutter through RenderEngine.frame_set, as
Cycles does, and restores the frame (export/motion.py); with Persistent Data a frame whose
export moves anything rebuilds the native scene (its arrays still come from the mesh cache).
"""
import fnmatch
import math
import threading
import time

import numpy as np

from . import export, native, properties, sync
from .properties import FILM_TRANSPARENT, declared, method_info

POLL_SECONDS = 0.02
# How often an F12 render's image reaches Blender: the first pass at once, then Cycles' ladder
# (render_scheduler.cpp, guess_display_update_interval_in_seconds: 0.25 s in the first 2 s of
# rendering, 0.5 s to 4 s, 1 s to 10 s; 2 s after, as its final renders), at the pass end nearest
# each interval. A pass is the smallest step, except for the methods whose pass can pause at a
# tile (pt, spt, spt-hero: the core's ProgressSink::pause): their pass stops when the next image
# is due and goes on after it, so a long pass (1920x1080) still refreshes on Cycles' ladder; the
# photon methods (ppm, sppm, sppm-adaptive, gpm, msppm), whose first pass pauses between its
# camera-path tiles and its stages, showing the light its camera paths saw until it ends; and gdmlt,
# whose every pass pauses with an image of its chains' splats so far (Method's
# paused_pass_covers_image: its first full pass too, once it holds as many mutations as the
# last reduced-size preview).
DISPLAY_INTERVAL = ((2.0, 0.25), (4.0, 0.5), (10.0, 1.0), (math.inf, 2.0))  # (until, interval), seconds
# Passes Film > Exposure scales, as Cycles scales its light passes (not data: error, radius,
# counts, alpha, albedo, normal, depth).
# Progressive resolution, as Cycles' start resolution: while a full pass would take longer than
# Cycles' one-second refresh, the first passes render the image at 1/8, 1/4, 1/2 of its size
# (its longer side at least PREVIEW_MIN_SIDE pixels), each shown enlarged, then discarded.
PREVIEW_DIVIDERS = (8, 4, 2)
PREVIEW_MIN_SIDE = 128
PREVIEW_FULL_PASS = 1.0  # seconds: a full pass expected faster than this needs no preview
PREVIEW_MAX = 0.5        # seconds a preview pass may be expected to take: each delays the full image
EXPOSED_PASSES = {"combined", "primal", "gradient_x", "gradient_y", "spectral_primal", "spectral_gradient",
                  "path_tracing"}
LAST = None  # the latest RenderSession (tests and the UI test inspect it)
REPORTS = []  # [(level, message)] of the latest render, shown in the Render tab's Last Render panel


# The auxiliary passes every method gets (native/integrators/aov.h), as Cycles registers them.
AUX_PASSES = {"albedo": ("RGB", 'COLOR'), "normal": ("XYZ", 'VECTOR'), "depth": ("Z", 'VALUE')}


def blender_passes():
    """[(native name, Blender pass name, channels, chan_id, type)] for every pass of the core but
    alpha, which is Combined's Alpha (Film > Transparent)."""
    out = []
    for name, channels, label in native.passes():
        if name == "alpha":
            continue
        if name == "combined":
            out.append((name, "Combined", 4, "RGBA", 'COLOR'))
        elif name in AUX_PASSES:  # Cycles' channel names and types for these
            out.append((name, label, channels) + AUX_PASSES[name])
        else:
            out.append((name, label, channels, "RGB" if channels == 3 else "X", 'COLOR' if channels == 3 else 'VALUE'))
    return out


def method_passes(method):
    """Names of the passes `method` writes (its own declaration), or None when unknown."""
    info = method_info(method)
    return set(info["passes"]) if info else None


def enabled_passes(view_layer, method=None):
    """The passes to register: Combined, and each enabled pass that `method` writes."""
    settings = getattr(view_layer, "gradphoton", None)
    produced = method_passes(method) if method else None
    return [p for p in blender_passes()
            if p[0] == "combined" or (settings is not None and getattr(settings, "use_pass_" + p[0], False)
                                      and (produced is None or p[0] in produced))]


def register_passes(engine, scene, view_layer):
    method = scene.gradphoton.method if scene is not None and hasattr(scene, "gradphoton") else None
    for name, bl_name, channels, chan_id, kind in enabled_passes(view_layer, method):
        engine.register_pass(scene, view_layer, bl_name, channels, chan_id, kind)


def animated_seed(seed, frame):
    """Cycles' Use Animated Seed: another seed every frame, the same for a frame every time (a
    hash of the frame and the seed; kept below 2^31 like Blender's integer properties)."""
    h = (seed * 0x9E3779B1 + frame * 0x85EBCA77 + 0x27D4EB2F) & 0xFFFFFFFF
    h ^= h >> 15
    h = (h * 0x2C1B3C6D) & 0xFFFFFFFF
    h ^= h >> 12
    return h & 0x7FFFFFFF


def params_of(settings, method=None, frame=None):
    """The native parameters for `method` (default: the chosen one) from the render settings;
    `frame` (the scene's current frame) turns the seed into an animated seed where the
    settings ask for one."""
    params = properties.params_of(settings, method)
    if frame is not None and getattr(settings, "use_animated_seed", False) and "seed" in params:
        params["seed"] = animated_seed(params["seed"], frame)
    return params


def method_stats(method, stats):
    """["label value", ...] for the method's key statistics (its declaration's, Method::stats)
    present in `stats`. A key with '*' sums every statistic it matches (fnmatch)."""
    out = []
    for key, label, form in (native.method_description(method) or {}).get("stats", ()):
        try:
            if "*" in key:
                values = [float(v) for k, v in stats.items() if fnmatch.fnmatchcase(k, key)]
                if not values:
                    continue
                value = sum(values)
            elif key in stats:
                value = float(stats[key])
            else:
                continue
            out.append(f"{label} {form.format(value)}")
        except (TypeError, ValueError):
            continue  # never fail the render for a statistic
    return out


def to_blender_pixels(img, channels, window=None, alpha=None):
    """(H, W, C) top-row-first float array -> (H*W, channels) bottom-row-first for foreach_set.
    RGB into RGBA takes `alpha` (H, W, 1) as its Alpha, else 1."""
    if window is not None:
        x0, y0, w, h = window
        H = img.shape[0]
        img = img[H - (y0 + h):H - y0, x0:x0 + w]
        if alpha is not None:
            alpha = alpha[H - (y0 + h):H - y0, x0:x0 + w]
    img = img[::-1]
    c = img.shape[2]
    if channels == 4 and c == 3:
        out = np.ones(img.shape[:2] + (4,), np.float32)
        out[..., :3] = img
        if alpha is not None:
            out[..., 3] = alpha[::-1, :, 0]
    elif channels == c:
        out = np.ascontiguousarray(img, dtype=np.float32)
    else:
        out = np.zeros(img.shape[:2] + (channels,), np.float32)
        out[..., :min(c, channels)] = img[..., :min(c, channels)]
    return out.reshape(-1, channels)


def previews_help(method, params=None):
    """Whether smaller first passes give earlier images: methods whose pass cost follows the pixel
    count: camera paths per pixel (pt, spt, gpt, sgpt), Metropolis mutations per pixel (gdmlt).
    Not the photon methods (a `photons` parameter: PPM, SPPM, SPPM Adaptive, Gradient Photons,
    Multisampled PPM), which pause their first pass between its camera-path tiles instead and
    show what those paths saw (ProgressivePhotonMapping::iterate, Msppm::iterate: PausableTiles);
    Multisampled PPM had previews while its first pass ran whole (17 s at 1920 x 1080)."""
    return not any(d["name"] == "photons" for d in declared(method))


def enlarged(img, height, width):
    """`img` (h, w, C) scaled to (height, width) by repeating pixels (nearest)."""
    h, w = img.shape[:2]
    ys = np.minimum(np.arange(height) * h // height, h - 1)
    xs = np.minimum(np.arange(width) * w // width, w - 1)
    return img[ys][:, xs]


def display_interval(elapsed):
    """Seconds between two images sent to Blender, `elapsed` seconds into the render."""
    return next(interval for until, interval in DISPLAY_INTERVAL if elapsed < until)


def film_exposure(scene):
    """Film > Exposure (Cycles' setting, a linear scale of the image; 1 without Cycles)."""
    c = getattr(scene, "cycles", None)
    return float(getattr(c, "film_exposure", 1.0)) if c is not None else 1.0


class Progress:
    """Stop rule bookkeeping: fraction done and the status line."""

    def __init__(self, settings):
        self.rule = settings.stop_rule or 'TIME'  # '' when a stored rule no longer applies
        self.seconds = settings.time_limit
        self.passes = settings.passes
        self.target = settings.target_error
        # Target Error's Time Limit, as Cycles': whichever comes first (0: none).
        self.error_seconds = getattr(settings, "error_time_limit", 0.0) if self.rule == 'ERROR' else 0.0
        self.start = time.perf_counter()

    def elapsed(self):
        return time.perf_counter() - self.start

    def fraction(self, passes, error):
        if self.rule == 'TIME':
            return min(1.0, self.elapsed() / self.seconds)
        if self.rule == 'PASSES':
            return min(1.0, passes / self.passes)
        by_time = min(1.0, self.elapsed() / self.error_seconds) if self.error_seconds > 0 else 0.0
        if error is None or error < 0 or error <= self.target:
            return 1.0 if error is not None and 0 <= error <= self.target else by_time
        return max(by_time, min(1.0, (self.target / error) ** 2))  # error ~ 1/sqrt(work)

    def done(self, passes, error):
        if self.rule == 'TIME':
            # Stop at the pass boundary nearest the budget: a method whose passes are long (GPM:
            # tens of seconds at 1080p) then ends as close to the budget as a method with short ones.
            el = self.elapsed()
            return el >= self.seconds or (passes >= 1 and el + 0.5 * el / passes >= self.seconds)
        if self.rule == 'PASSES':
            return passes >= self.passes
        if self.error_seconds > 0 and self.elapsed() >= self.error_seconds:
            return True
        return error is not None and 0 <= error <= self.target

    def timed_out(self, error):
        """The Target Error rule stopped on its Time Limit before the target."""
        return (self.rule == 'ERROR' and self.error_seconds > 0 and self.elapsed() >= self.error_seconds
                and not (error is not None and 0 <= error <= self.target))

    def status(self, stats, error, method=""):
        f = self.fraction(stats.get("passes", 0), error)
        el = self.elapsed()
        parts = [f"Pass {stats.get('passes', 0)}"]
        photons = stats.get("photons", stats.get("photons traced"))
        if photons:
            parts.append(f"{int(photons):,} photons")
        else:
            parts.append(f"{int(stats.get('paths', 0)):,} paths")
        if error is not None and 0 <= error < math.inf:
            parts.append(f"error {error:.4f}")
        parts.extend(method_stats(method, stats))
        if 0 < f < 1:
            parts.append(f"{el * (1 - f) / f:.1f} s left")
        # No elapsed time: Blender's own stats beside this line show it (Time: 00:04.52).
        return " | ".join(parts)


class PersistentScene:
    """What an engine keeps between frames with Persistent Data: the sync state and the native
    scene it describes."""

    def __init__(self):
        self.sync = sync.SceneSync()
        self.scene = None
        self.plans = []  # the kinds of each frame's plan (tests: ["rebuild"], ["transforms"], ...)

    def scene_for(self, depsgraph, N, export_uvs, frame_set=None):
        """(ExportedScene, native Scene) for this frame: updated in place where possible
        (`frame_set`: motion blur, export.export_scene)."""
        first = self.scene is None
        plan = self.sync.sync(depsgraph, export_uvs=export_uvs, first=first, frame_set=frame_set)
        self.plans.append(plan.kinds())
        try:
            self.scene = sync.apply(plan, self.scene, N)
        except ValueError:
            if plan.rebuild is not None:
                raise
            self.plans[-1] = ["rebuild"]
            self.scene = sync.apply(sync.Plan(rebuild=plan.exported), None, N)
        return plan.exported, self.scene


class RenderSession:
    """The render loop. Blender callbacks are injected so tests can drive it (e.g. a
    test_break that fires after some time to measure cancellation latency)."""

    def __init__(self, engine, test_break=None):
        self.engine = engine
        self.test_break = test_break or engine.test_break
        self.session = None
        # Combined's Alpha from the core's alpha pass: with Film > Transparent, and on a scene that
        # holds out whatever the film (Cycles 3.4 gives held-out pixels alpha 0 either way; the
        # method declares it: Session.passes, integrators/integrator.h writes_alpha).
        self.transparent = False
        self.cancel_latency = None  # seconds from test_break() to the loop's end
        self.updates = []           # (seconds, passes) of every image sent to Blender
        self.break_at = None        # wall clock (time.time()) when test_break() first fired
        self.finished_at = None     # wall clock when render() returned
        self.status_line = ""       # the latest status line sent to Blender
        self.exposure = 1.0         # Film > Exposure
        self.reports = REPORTS      # what this render reported, also shown in the Last Render panel
        self.deferred = []          # warnings for Blender's status bar, sent when the render ends
        self.preview_seconds = 0.0  # how long the last reduced-size preview pass took (_previews)
        REPORTS.clear()
        global LAST
        LAST = self

    def report(self, level, message, defer=False):
        """Blender's report (the status bar, the Info editor) and the Last Render panel. A
        `defer`red warning is in the panel at once and goes to Blender when the render ends:
        Blender's status bar shows a warning for 5 s from the moment it is reported (an error
        10 s: wm_operators, INFO_TIMEOUT / ERROR_TIMEOUT), which ran out while F12's window
        was opening when the export's warnings were reported at once."""
        self.reports.append((level, message))
        if defer:
            self.deferred.append((level, message))
        else:
            self.engine.report({level}, message)

    def _send_deferred(self):
        for level, message in self.deferred:
            self.engine.report({level}, message)
        self.deferred.clear()

    def render(self, depsgraph):
        try:
            self._render(depsgraph)
        finally:
            self._send_deferred()  # also when the export or the session failed

    def _render(self, depsgraph):
        engine = self.engine
        try:
            N = native.get()
        except RuntimeError as e:
            self.report('ERROR', str(e))
            return
        scene = depsgraph.scene
        view_layer = depsgraph.view_layer
        settings = scene.gradphoton
        try:
            engine.update_stats("", "Exporting scene")
            persistent = getattr(engine, "persistent", None) if scene.render.use_persistent_data else None
            # Motion blur samples the scene over the shutter through the engine (Cycles' frame_set).
            frame_set = getattr(engine, "frame_set", None)
            if persistent is not None:
                exported, nscene = persistent.scene_for(depsgraph, N, settings.export_uvs, frame_set)
            else:
                if hasattr(engine, "persistent"):
                    engine.persistent = PersistentScene()  # switched off: the next frame starts anew
                exported = export.export_scene(depsgraph, export_uvs=settings.export_uvs, frame_set=frame_set)
                engine.update_stats("", f"Building scene ({exported.triangle_count:,} triangles)")
                nscene = exported.build(N)
            if exported.warnings:
                self.report('WARNING', exported.warnings.summary(), defer=True)
            params = params_of(settings, settings.method, frame=scene.frame_current)
            if any(d["name"] == FILM_TRANSPARENT for d in declared(settings.method)):
                params[FILM_TRANSPARENT] = bool(scene.render.film_transparent)
            self.session = N.Session(nscene, settings.method, params)
        except (ValueError, TypeError, RuntimeError) as e:  # SceneError, ParamError: one readable line
            self.report('ERROR', f"gradphoton: {e}")
            return
        except Exception as e:  # an exporter bug: still one report, never a failed render engine
            import traceback
            traceback.print_exc()  # the details, for a bug report, on the console only
            self.report('ERROR', f"gradphoton: internal error exporting the scene ({type(e).__name__}: {e}); "
                                 "please report it with the console output")
            return
        for w in nscene.warnings:
            self.report('WARNING', f"gradphoton scene: {w}", defer=True)
        # The session sends only what the method declares: a name it does not know is a bug here.
        for line in self.session.unused_report:
            if "is not a parameter of" in line:
                self.report('WARNING', f"gradphoton: {line}", defer=True)
        for line in self.session.feature_report:  # a scene feature the method leaves out (media)
            self.report('WARNING', f"gradphoton: {line}", defer=True)
        if settings.stop_rule == 'ERROR':  # what Target Error asks that the method cannot give (media)
            for line in self.session.stop_report(seconds=getattr(settings, "error_time_limit", 0.0),
                                                 target_error=settings.target_error):
                self.report('WARNING', f"gradphoton: {line}", defer=True)
        if scene.render.film_transparent and (FILM_TRANSPARENT in self.session.unused_params
                                              or FILM_TRANSPARENT not in params):
            self.report('WARNING', f"gradphoton: {self.session.method} has no transparent film: "
                                   "the background stays opaque", defer=True)
        self.exposure = film_exposure(scene)
        self.transparent = "alpha" in self.session.passes
        W, H = exported.width, exported.height
        window = exported.border
        rw, rh = (window[2], window[3]) if window else (W, H)
        passes = enabled_passes(view_layer, settings.method)
        self.session.set_aux_passes(any(p[0] in AUX_PASSES for p in passes))  # no cost unless asked for
        result = engine.begin_result(0, 0, rw, rh, layer=view_layer.name)
        progress = Progress(settings)
        last_update = -math.inf
        n = 0
        previewed = False
        # A pass paused part-way shows every pixel (gdmlt): its first full pass may pause too.
        covers = bool((native.method_description(settings.method) or {}).get("paused_pass_covers_image"))
        full_from = 0.0  # when the full-size passes began
        try:
            if window is None and previews_help(settings.method, params) and progress.rule != 'PASSES':
                previewed = self._previews(N, nscene, exported.description["camera"], settings.method, params,
                                           result, passes, progress)
                if previewed:
                    last_update = full_from = progress.elapsed()
            while True:
                # Until the next image is due (a method whose pass cannot pause ignores it). The
                # first pass of a method with reduced-resolution previews runs whole (every pixel
                # a sample), but gdmlt's (`covers`); a photon method's first pause shows its
                # camera paths' direct light.
                due = max(POLL_SECONDS, last_update + display_interval(progress.elapsed()) - progress.elapsed())
                whole = (self.session.stats.get("passes", 0) < 1 and previews_help(settings.method, params)
                         and not covers) or not math.isfinite(due)
                cancelled_at = self._iterate_cancellable(0.0 if whole else due)
                stats = self.session.stats
                n = stats.get("passes", n + 1)
                error = self.session.estimated_error
                done = cancelled_at is not None or progress.done(n, error)
                now = progress.elapsed()
                # The pass end nearest the interval: half a pass early rather than a whole one late.
                half_pass = 0.5 * now / max(1, n)
                if previewed and stats.get("passes", 0) == 0 and not (
                        covers and now - full_from >= self.preview_seconds):
                    # Stopped before a full pass: the preview stays, not an empty image (a method
                    # whose paused pass covers the image: until it has run as long as the last
                    # preview, so holds about as many samples, spread over the full size).
                    pass
                elif done or now - last_update + half_pass >= display_interval(now):
                    # Display quality until the end; after Esc too (an L1 solve at 1080p would
                    # hold the cancel for many seconds).
                    self._write(result, passes, display=not done or cancelled_at is not None)
                    engine.update_result(result)
                    self.updates.append((now, n))
                    last_update = now
                self.status_line = progress.status(stats, error, settings.method)
                engine.update_stats("", self.status_line)
                engine.update_progress(progress.fraction(n, error))
                if cancelled_at is not None:
                    self.cancel_latency = time.perf_counter() - cancelled_at
                    self.break_at = time.time() - self.cancel_latency
                    break
                if done:
                    if progress.timed_out(error):
                        at = (f"at estimated error {error:.4f}" if error is not None and error >= 0
                              else "without an error estimate")
                        self.report('INFO', f"gradphoton: Time Limit reached {at} "
                                            f"(Target Error {progress.target:g})", defer=True)
                    break
                if progress.rule == 'ERROR' and error < 0 and n >= 1 and progress.error_seconds <= 0:
                    self.report('ERROR', f"gradphoton: method '{settings.method}' has no error estimate; "
                                         "choose a time or pass stop rule")
                    break
        finally:
            self._stamp()
            engine.end_result(result)
            self.finished_at = time.time()

    def _stamp(self):
        """The run's record (gradphoton.method, .seed, .passes, ...: distributed/run_info.h) into
        the render result's metadata, which Blender writes into the header of the EXR it saves:
        the files `gradphoton merge` combines."""
        try:
            full = self.engine.get_result()
            for key, value in self.session.run_info.items():
                full.stamp_data_add_field(key, value)
        except (AttributeError, RuntimeError, TypeError) as e:  # never fail the render for metadata
            self.engine.report({'WARNING'}, f"gradphoton: run metadata not recorded: {e}")

    def _previews(self, N, nscene, camera, method, params, result, passes, progress):
        """The progressive-resolution first passes (PREVIEW_DIVIDERS): each a session of its own on
        the camera made smaller, one pass, its image enlarged into the result; the camera is
        restored and the full-size session made anew after them. Returns whether any was shown."""
        import json
        W, H = camera["width"], camera["height"]
        shown = False
        full = self.session
        last = None  # (divider, seconds) of the latest preview pass
        try:
            for d in PREVIEW_DIVIDERS:
                w, h = math.ceil(W / d), math.ceil(H / d)
                if max(w, h) < PREVIEW_MIN_SIDE:
                    continue
                if last is not None and last[1] * (last[0] / d) ** 2 > PREVIEW_MAX:
                    break  # it would hold the first full image back for longer than it shows

                nscene.set_camera(json.dumps(dict(camera, width=w, height=h)))
                self.session = N.Session(nscene, method, params)
                self.session.set_aux_passes(False)
                t0 = time.perf_counter()
                if self._iterate_cancellable() is not None:
                    break
                seconds = time.perf_counter() - t0
                images = {k: enlarged(v, H, W) for k, v in self.session.develop(display=True).items()
                          if k in ("combined", "alpha")}
                self._write(result, [p for p in passes if p[0] == "combined"], images)
                self.engine.update_result(result)
                self.updates.append((progress.elapsed(), 0))
                shown = True
                last = (d, seconds)
                self.preview_seconds = seconds
                if seconds * d * d <= PREVIEW_FULL_PASS:
                    break  # a full pass will be about as quick: no smaller one is needed
        finally:
            nscene.set_camera(json.dumps(camera))
            self.session = N.Session(nscene, method, params) if shown or full.stale else full
            self.session.set_aux_passes(any(p[0] in AUX_PASSES for p in passes))
        return shown

    def _iterate_cancellable(self, seconds=0.0):
        """Runs one pass (with seconds > 0, a pausable pass for about that long: Session.iterate);
        returns the time test_break() fired, or None."""
        if self.test_break():
            self.session.cancel()
            return time.perf_counter()
        worker = threading.Thread(target=self.session.iterate, args=(seconds,), name="gradphoton pass")
        worker.start()
        fired = None
        while worker.is_alive():
            worker.join(POLL_SECONDS)
            if fired is None and self.test_break():
                fired = time.perf_counter()
                self.session.cancel()
        return fired

    def _write(self, result, passes, images=None, display=False):
        """Every enabled pass into the result (a border render's images are already the
        border: the core traced only its pixels); `images` instead of the session's own.
        display: an image shown while the render goes on (Session.develop's display: a gradient
        method's L1 solve replaced by L2); the last image is the method's own."""
        if images is None:
            images = self.session.develop(display=display)
        layer = result.layers[0]
        alpha = images.get("alpha") if self.transparent else None
        for name, bl_name, channels, _, _ in passes:
            rp = layer.passes.find_by_name(bl_name, "")
            if rp is None:
                continue
            img = images.get(name)
            if img is None:
                continue  # the method does not produce this pass: Blender keeps it zero
            if self.exposure != 1.0 and name in EXPOSED_PASSES:
                img = img * np.float32(self.exposure)
            rp.rect.foreach_set(to_blender_pixels(img, channels, None, alpha if name == "combined" else None))
