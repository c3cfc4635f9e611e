"""One render: export, then a progressive loop on the native Session with Blender's progress,
stats, cancellation and passes. engine.py delegates here; nothing here is a Blender class.

Cancellation: each pass runs in a worker thread (the native call releases the GIL); the render
thread polls test_break() every 20 ms and calls Session.cancel(), which stops the pass between
tiles; the image so far is kept and returned.

Persistent Data (Render > Performance, as Cycles'): Blender keeps the engine between frames and
the native scene stays with it (PersistentScene); each frame syncs what changed (sync.py: moved
objects are transformed natively, unchanged meshes are not exported again).

Border: the camera's crop window (export/camera.py), so only the border's pixels are traced.
"""
import fnmatch
import math
import threading
import time

import numpy as np

from . import export, native, properties, sync
from .properties import FILM_TRANSPARENT, declared, method_info

POLL_SECONDS = 0.02
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


class Progress:
    """Stop rule bookkeeping: fraction done and the status line."""

    def __init__(self, settings):
        self.rule = settings.stop_rule or 'TIME'  # '' when a stored rule no longer applies
        self.seconds = settings.time_limit
        self.passes = settings.passes
        self.target = settings.target_error
        self.start = time.perf_counter()

    def elapsed(self):
        return time.perf_counter() - self.start

    def fraction(self, passes, error):
        if self.rule == 'TIME':
            return min(1.0, self.elapsed() / self.seconds)
        if self.rule == 'PASSES':
            return min(1.0, passes / self.passes)
        if error is None or error < 0 or error <= self.target:
            return 1.0 if error is not None and 0 <= error <= self.target else 0.0
        return min(1.0, (self.target / error) ** 2)  # error ~ 1/sqrt(work)

    def done(self, passes, error):
        if self.rule == 'TIME':
            # Stop at the pass boundary nearest the budget: a method whose passes are long (GPM:
            # tens of seconds at 1080p) then ends as close to the budget as a method with short ones.
            el = self.elapsed()
            return el >= self.seconds or (passes >= 1 and el + 0.5 * el / passes >= self.seconds)
        if self.rule == 'PASSES':
            return passes >= self.passes
        return error is not None and 0 <= error <= self.target

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
        parts.append(f"{el:.1f} s")
        return " | ".join(parts)


class PersistentScene:
    """What an engine keeps between frames with Persistent Data: the sync state and the native
    scene it describes."""

    def __init__(self):
        self.sync = sync.SceneSync()
        self.scene = None
        self.plans = []  # the kinds of each frame's plan (tests: ["rebuild"], ["transforms"], ...)

    def scene_for(self, depsgraph, N, export_uvs):
        """(ExportedScene, native Scene) for this frame: updated in place where possible."""
        first = self.scene is None
        plan = self.sync.sync(depsgraph, export_uvs=export_uvs, first=first)
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
        self.transparent = False    # Combined's Alpha from the core's alpha pass (Film > Transparent)
        self.cancel_latency = None  # seconds from test_break() to the loop's end
        self.updates = []           # (seconds, passes) of every image sent to Blender
        self.break_at = None        # wall clock (time.time()) when test_break() first fired
        self.finished_at = None     # wall clock when render() returned
        self.status_line = ""       # the latest status line sent to Blender
        self.reports = REPORTS      # what this render reported, also shown in the Last Render panel
        REPORTS.clear()
        global LAST
        LAST = self

    def report(self, level, message):
        """Blender's report (the status bar, the Info editor) and the Last Render panel."""
        self.reports.append((level, message))
        self.engine.report({level}, message)

    def render(self, depsgraph):
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
            if persistent is not None:
                exported, nscene = persistent.scene_for(depsgraph, N, settings.export_uvs)
            else:
                if hasattr(engine, "persistent"):
                    engine.persistent = PersistentScene()  # switched off: the next frame starts anew
                exported = export.export_scene(depsgraph, export_uvs=settings.export_uvs)
                engine.update_stats("", f"Building scene ({exported.triangle_count:,} triangles)")
                nscene = exported.build(N)
            if exported.warnings:
                self.report('WARNING', exported.warnings.summary())
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
            self.report('WARNING', f"gradphoton scene: {w}")
        # The session sends only what the method declares: a name it does not know is a bug here.
        for line in self.session.unused_report:
            if "is not a parameter of" in line:
                self.report('WARNING', f"gradphoton: {line}")
        for line in self.session.feature_report:  # a scene feature the method leaves out (media)
            self.report('WARNING', f"gradphoton: {line}")
        if scene.render.film_transparent and (FILM_TRANSPARENT in self.session.unused_params
                                              or FILM_TRANSPARENT not in params):
            self.report('WARNING', f"gradphoton: {self.session.method} has no transparent film: "
                                   "the background stays opaque")
        self.transparent = (scene.render.film_transparent and FILM_TRANSPARENT in params
                            and FILM_TRANSPARENT not in self.session.unused_params)
        W, H = exported.width, exported.height
        window = exported.border
        rw, rh = (window[2], window[3]) if window else (W, H)
        passes = enabled_passes(view_layer, settings.method)
        self.session.set_aux_passes(any(p[0] in AUX_PASSES for p in passes))  # no cost unless asked for
        result = engine.begin_result(0, 0, rw, rh, layer=view_layer.name)
        progress = Progress(settings)
        last_update = -1.0
        interval = 0.25
        n = 0
        try:
            while True:
                cancelled_at = self._iterate_cancellable()
                stats = self.session.stats
                n = stats.get("passes", n + 1)
                error = self.session.estimated_error
                done = cancelled_at is not None or progress.done(n, error)
                now = progress.elapsed()
                if done or now - last_update >= interval:
                    self._write(result, passes)
                    engine.update_result(result)
                    self.updates.append((now, n))
                    last_update = now
                    interval = min(2.0, interval * 1.5)
                self.status_line = progress.status(stats, error, settings.method)
                engine.update_stats("", self.status_line)
                engine.update_progress(progress.fraction(n, error))
                if cancelled_at is not None:
                    self.cancel_latency = time.perf_counter() - cancelled_at
                    self.break_at = time.time() - self.cancel_latency
                    break
                if done:
                    break
                if progress.rule == 'ERROR' and error < 0 and n >= 1:
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

    def _iterate_cancellable(self):
        """Runs one pass; returns the time test_break() fired, or None."""
        if self.test_break():
            self.session.cancel()
            return time.perf_counter()
        worker = threading.Thread(target=self.session.iterate, name="gradphoton pass")
        worker.start()
        fired = None
        while worker.is_alive():
            worker.join(POLL_SECONDS)
            if fired is None and self.test_break():
                fired = time.perf_counter()
                self.session.cancel()
        return fired

    def _write(self, result, passes):
        """Every enabled pass into the result (a border render's images are already the
        border: the core traced only its pixels)."""
        images = self.session.develop()
        layer = result.layers[0]
        alpha = images.get("alpha") if self.transparent else None
        for name, bl_name, channels, _, _ in passes:
            rp = layer.passes.find_by_name(bl_name, "")
            if rp is None:
                continue
            img = images.get(name)
            if img is None:
                continue  # the method does not produce this pass: Blender keeps it zero
            rp.rect.foreach_set(to_blender_pixels(img, channels, None, alpha if name == "combined" else None))
