"""The rendered viewport (a 3D view in Rendered shading), as Cycles' viewport: engine.py's
view_update / view_draw delegate here; nothing here is a Blender class.

  view_update (Blender's UI thread, on every depsgraph change): sync.py exports what changed
      (mesh arrays from a cache) and turns it into a Plan; the plan goes to the worker and the
      pass in progress is cancelled.
  view_draw (UI thread, on every redraw): the view's camera from the region (a changed view is
      a new camera for the worker), then the latest image as a GPU texture (Blender's `gpu`
      module), drawn over the region; Blender applies the view transform to the viewport.
  worker (one thread per viewport): applies plans to the one native scene it keeps (camera and
      object moves, material edits: no mesh is exported again, only the moved meshes' part of
      the BVH changes), then refines: one pass at a reduced resolution (the longer side about
      START_RESOLUTION pixels, as Cycles' start resolution), halving the pixel size pass by
      pass, then passes at full resolution until the viewport's pass count. Each new image
      asks Blender to redraw: a flag the worker raises and a timer on Blender's main thread
      passes on (RenderEngine.tag_redraw; the worker never calls Blender's API).

Render region (Cycles' viewport border: View > Render Region, Ctrl+B): in a view through the scene
camera, the scene's render border (Output > Format > Render Region) within the camera frame;
in any other view, the view's own region (SpaceView3D.use_render_border). Only its pixels are
traced (the camera's crop window, as a border render's) and drawn where they are in the view; the
rest of the view stays empty, as Cycles leaves it.

Never blocks Blender's UI thread on native work: native calls run on the worker with the GIL
released; the UI thread only cancels (Session.cancel: the pass stops between tiles). Work stops
when the engine is freed (leaving Rendered shading, closing the view): engine.py's __del__ calls
free(); the worker also stops by itself once the engine is gone (a weak reference).
"""
import math
import threading
import time
import weakref

import numpy as np

from . import native, sync
from .export import camera as camera_export
from .export import Warnings
from .properties import FILM_TRANSPARENT, declared
from .session import params_of

START_RESOLUTION = 64      # pixels on the longer side of the first pass (Cycles' default)
REDRAW_POLL = 0.02         # seconds between the main thread's checks for a new image
IDLE_WAIT = 0.25           # seconds the worker sleeps between checks when it has nothing to do
LAST = None                # the latest ViewportSession (tests and benchmarks inspect it)
# GPU textures let go of on another thread (an engine freed while the worker held it): a GPU
# object must be freed where Blender's GPU context is, on its main thread, so they wait here for
# the next draw.
_RETIRED = []


def _on_main_thread():
    return threading.current_thread() is threading.main_thread()


def view_camera(context, scene, width, height):
    """The scene-format camera (a JSON-able dict) of the 3D view's region: its view matrix and
    projection (perspective or orthographic, off-centre as the view's window matrix says: a
    camera view with zoom and offset, or a panned view), `width` x `height` pixels."""
    rv3d, space = context.region_data, context.space_data
    view = rv3d.view_matrix.inverted()
    P = rv3d.window_matrix
    d = {"width": int(width), "height": int(height), "sensor_fit": "horizontal"}
    in_camera = rv3d.view_perspective == 'CAMERA' and scene.camera is not None
    cam = camera_export.export_camera(scene, Warnings())[0] if in_camera else None
    if rv3d.is_perspective:
        ext = (1.0 / P[0][0], 1.0 / P[1][1])            # tan of the half angles
        centre = (P[0][2] / P[0][0], P[1][2] / P[1][1])  # the frustum's off-centre at distance 1
        d["fov"] = math.degrees(2.0 * math.atan(ext[0]))
    else:
        ext = (1.0 / P[0][0], 1.0 / P[1][1])             # metres
        centre = (-P[0][3] / P[0][0], -P[1][3] / P[1][1])
        d["type"] = "orthographic"
        d["ortho_scale"] = 2.0 * ext[0]
        if not in_camera:
            # Blender's orthographic views see behind their origin (clipping from -clip_end / 2):
            # start the rays that far back.
            back = 0.5 * getattr(space, "clip_end", 1000.0)
            z = view.col[2].xyz.normalized()
            view.translation = view.translation + z * back
    s = 2.0 * max(ext[0], ext[0] * height / max(1, width))  # the larger extent (camera.h shift)
    if abs(centre[0]) > 1e-7 or abs(centre[1]) > 1e-7:
        d["shift"] = [centre[0] / s, centre[1] / s]
    rot = view.to_quaternion().to_matrix()
    t = view.translation
    d["matrix"] = [rot[0][0], rot[0][1], rot[0][2], t[0], rot[1][0], rot[1][1], rot[1][2], t[1],
                   rot[2][0], rot[2][1], rot[2][2], t[2], 0, 0, 0, 1]
    # Clip Start / End as Cycles' viewport takes them (blender/camera.cpp blender_camera_from_view):
    # through the scene camera its own (as F12), in a perspective view the view's (View > Clip
    # Start / End), in an orthographic view -clip_end / 2 to clip_end / 2 about the view plane
    # (from the origin moved back above: 0 to clip_end).
    if in_camera:
        clip = (cam.get("clip_start", 0.0), cam.get("clip_end"))
    elif rv3d.is_perspective:
        clip = (float(getattr(space, "clip_start", 0.0)), float(getattr(space, "clip_end", 0.0)) or None)
    else:
        clip = (0.0, float(getattr(space, "clip_end", 1000.0)))
    if clip[0] > 0:
        d["clip_start"] = clip[0]
    if clip[1] is not None and clip[1] > clip[0]:
        d["clip_end"] = clip[1]
    if rv3d.is_perspective and in_camera:
        # Looking through the scene camera: its depth of field too (Cycles does).
        for key in ("aperture_radius", "focus_distance"):
            if key in cam:
                d[key] = cam[key]
    region = render_region(context, scene, width, height)
    if region is not None:  # the core's crop window: rows from the top
        x0, y0, x1, y1 = region
        d["crop"] = [x0, int(height) - y1, x1 - x0, y1 - y0]
    return d


def camera_frame(context, scene):
    """The scene camera's frame in the 3D view's region: (x0, y0, x1, y1) in pixels from the
    region's bottom-left corner (its corners projected as the view draws them), or None."""
    from bpy_extras.view3d_utils import location_3d_to_region_2d
    cam = scene.camera
    corners = [cam.matrix_world @ v for v in cam.data.view_frame(scene=scene)]
    pts = [location_3d_to_region_2d(context.region, context.region_data, c) for c in corners]
    if any(p is None for p in pts):
        return None
    return (min(p.x for p in pts), min(p.y for p in pts), max(p.x for p in pts), max(p.y for p in pts))


def render_region(context, scene, width, height):
    """The part of the `width` x `height` view to render, as Cycles chooses it: the scene's render
    border within the camera frame in a view through the scene camera (when the render settings
    use one), else the view's own render region (when it has one). (x0, y0, x1, y1) in whole
    pixels from the bottom-left corner, at least one pixel; None for the whole view."""
    rv3d, space = context.region_data, context.space_data
    if rv3d.view_perspective == 'CAMERA' and scene.camera is not None:
        r = scene.render
        frame = camera_frame(context, scene) if r.use_border else None
        if frame is None:
            return None
        fx0, fy0, fx1, fy1 = frame
        box = (fx0 + r.border_min_x * (fx1 - fx0), fy0 + r.border_min_y * (fy1 - fy0),
               fx0 + r.border_max_x * (fx1 - fx0), fy0 + r.border_max_y * (fy1 - fy0))
    elif getattr(space, "use_render_border", False):
        box = (space.render_border_min_x * width, space.render_border_min_y * height,
               space.render_border_max_x * width, space.render_border_max_y * height)
    else:
        return None
    x0 = min(max(0, math.floor(box[0])), width - 1)
    y0 = min(max(0, math.floor(box[1])), height - 1)
    x1 = max(x0 + 1, min(width, math.ceil(box[2])))
    y1 = max(y0 + 1, min(height, math.ceil(box[3])))
    if (x0, y0, x1, y1) == (0, 0, width, height):
        return None
    return x0, y0, x1, y1


def scaled_crop(crop, width, height, divider):
    """A crop window [x, y, w, h] (pixels from the top-left) of a `width` x `height` image in
    pixels of that image reduced by `divider` (the whole reduced pixels that cover it: a reduced
    pixel spans width / rw of the view), and the reduced image's size (rw, rh)."""
    rw, rh = max(1, math.ceil(width / divider)), max(1, math.ceil(height / divider))
    x, y, w, h = crop
    x0, y0 = min(x * rw // width, rw - 1), min(y * rh // height, rh - 1)
    x1 = min(rw, max(x0 + 1, -(-(x + w) * rw // width)))  # (ceilings in integers)
    y1 = min(rh, max(y0 + 1, -(-(y + h) * rh // height)))
    return [x0, y0, x1 - x0, y1 - y0], rw, rh


def dividers(width, height):
    """Pixel sizes of the passes before full resolution: START_RESOLUTION on the longer side,
    halved each pass (64 px first, as Cycles)."""
    d = 1
    while max(width, height) / (2 * d) >= START_RESOLUTION:
        d *= 2
    out = []
    while d >= 1:
        out.append(d)
        d //= 2
    return out


def viewport_config(scene):
    """(method, params) the viewport renders with: the viewport's method (default: the render
    method), the render settings' parameters, no auxiliary passes."""
    settings = scene.gradphoton
    method = settings.viewport_method
    if method == 'RENDER' or not method:
        method = settings.method
    params = params_of(settings, method, frame=scene.frame_current)
    if any(d["name"] == FILM_TRANSPARENT for d in declared(method)):
        params[FILM_TRANSPARENT] = bool(scene.render.film_transparent)
    return method, params


class ViewportSession:
    def __init__(self, engine):
        global LAST
        LAST = self
        self._engine = weakref.ref(engine)
        self.sync = sync.SceneSync()
        self.lock = threading.Condition()
        self.thread = None
        self.stopped = False
        # Shared with the worker (under `lock`):
        self.plan = None          # sync.Plan not applied yet
        self.config = None        # (method, params)
        self.config_changed = False
        self.camera = None        # the view's camera dict (full resolution)
        self.camera_changed = False
        self.max_passes = 0
        self.request = None       # (kind, perf_counter) of the latest change asked for
        self.image = None         # (serial, float32 array (H, W, 4) bottom row first, placement)
        #                           placement: (x, y, w, h) fractions of the view from its
        #                           bottom-left corner (a render region), or None (all of it)
        self.serial = 0
        self.status = ""
        self.error = None
        self.native = None        # the native Session the worker iterates (cancel)
        self.busy = False         # the worker has work left (Blender keeps redrawing)
        # Measurements (tests, scripts/bench_viewport.py):
        self.events = []          # (kind, seconds from the request to the first image of it)
        self._full = None         # the request whose full-resolution image is still to come
        self.freed_at = self.exited_at = None  # perf_counter() of free() and of the worker's end
        self.passes = 0           # passes of the current image
        self.pass_seconds = None  # its render time per pass (tests: a render region's speed-up)
        self.divider = 1
        self.placement = None     # where the current session's image goes (see `image`)
        # UI thread only:
        self._texture = None
        self._texture_serial = -1
        self.redraw_wanted = False  # set by the worker, taken by _redraw_poller

    # ---- Blender's UI thread ----

    def view_update(self, context, depsgraph):
        try:
            native.get()
        except RuntimeError as e:
            self._fail(str(e))
            return
        scene = depsgraph.scene
        t0 = time.perf_counter()  # the request's time: the export counts too
        try:
            first = self.thread is None
            plan = self.sync.sync(depsgraph, export_uvs=scene.gradphoton.export_uvs, first=first)
            config = viewport_config(scene)
        except Exception as e:  # an exporter bug: one line in the viewport, details on the console
            import traceback
            traceback.print_exc()
            self._fail(f"gradphoton: viewport export failed ({type(e).__name__}: {e})")
            return
        with self.lock:
            changed = False
            if not plan.empty:
                self.plan = plan if self.plan is None else self.plan.merged(plan)
                changed = True
            if config != self.config:
                self.config, self.config_changed, changed = config, True, True
            self.max_passes = scene.gradphoton.viewport_passes
            if changed:
                kind = "first" if first else ",".join(plan.kinds() or ["settings"])
                self.request = (kind, t0)
                self.error = None
                self._cancel_locked()
                self.lock.notify_all()
        if self.thread is None:
            self.thread = threading.Thread(target=self._run, name="gradphoton viewport", daemon=True)
            self.thread.start()
            import bpy
            bpy.app.timers.register(_redraw_poller(self), first_interval=REDRAW_POLL)

    def view_draw(self, engine, context, depsgraph):
        _RETIRED.clear()  # (Blender's main thread)
        region = context.region
        w, h = region.width, region.height
        if w < 1 or h < 1:
            return
        try:
            cam = view_camera(context, depsgraph.scene, w, h)
        except Exception as e:
            self._fail(f"gradphoton: viewport camera ({type(e).__name__}: {e})")
            cam = None
        if cam is not None:
            with self.lock:
                if cam != self.camera:
                    if self.camera is not None:  # the first camera belongs to the first image
                        self.request = ("camera", time.perf_counter())
                    self.camera, self.camera_changed = cam, True
                    self._cancel_locked()
                    self.lock.notify_all()
        try:
            self._draw(engine, depsgraph.scene, w, h)
        except Exception as e:  # a GPU failure: one line in the view, never a traceback per redraw
            self.error = f"gradphoton: viewport drawing failed ({type(e).__name__}: {e})"
        engine.update_stats("", self.error or self.status)

    def _draw(self, engine, scene, w, h):
        import gpu
        from gpu_extras.presets import draw_texture_2d
        image = self.image
        if image is None or self.stopped:
            return
        serial, pixels, placement = image
        if serial != self._texture_serial:
            ih, iw = pixels.shape[:2]
            buf = gpu.types.Buffer('FLOAT', iw * ih * 4, pixels.reshape(-1))
            self._texture = gpu.types.GPUTexture((iw, ih), format='RGBA16F', data=buf)
            self._texture_serial = serial
        texture = self._texture  # (held here: the worker may drop the attribute when it stops)
        if texture is None:
            return
        gpu.state.blend_set('ALPHA_PREMULT')
        engine.bind_display_space_shader(scene)
        if placement is None:
            draw_texture_2d(texture, (0, 0), w, h)
        else:  # a render region: its pixels where they are, the rest of the view left empty
            x, y, pw, ph = placement
            draw_texture_2d(texture, (x * w, y * h), pw * w, ph * h)
        engine.unbind_display_space_shader()
        gpu.state.blend_set('NONE')

    def free(self):
        """Stops the worker (never waits for it: the pass in progress is cancelled and the
        thread ends on its own within about half a second)."""
        with self.lock:
            self.stopped = True
            self.freed_at = time.perf_counter()
            self._cancel_locked()
            self.lock.notify_all()
        self._drop_texture()

    def _drop_texture(self):
        texture, self._texture = self._texture, None
        if texture is not None and not _on_main_thread():
            _RETIRED.append(texture)  # freed by the next draw, on Blender's thread

    def _cancel_locked(self):
        if self.native is not None:
            self.native.cancel()

    def _fail(self, message):
        with self.lock:
            self.error = message
            self.busy = False
        self._tag_redraw()

    # ---- The worker thread ----

    def _tag_redraw(self):
        """Asks for a redraw; False once Blender has freed the engine. Blender's API is called
        on its main thread only (_redraw_poller): the worker only raises a flag."""
        self.redraw_wanted = True
        return self._engine() is not None

    def _run(self):
        N = native.get()
        scene = None          # the native scene
        session = None        # the native Session of the current image
        steps = []            # pixel sizes still to render at reduced resolution
        camera = None
        while True:
            with self.lock:
                while not self.stopped and self.plan is None and not self.camera_changed and \
                        not self.config_changed and (session is None or not self.busy):
                    self.lock.wait(IDLE_WAIT)
                    if self._engine() is None:
                        self.stopped = True
                if self.stopped:
                    self.native = None
                    self.exited_at = time.perf_counter()
                    # This thread may hold the session's last reference: its texture must not
                    # be freed here when the session goes.
                    self._drop_texture()
                    return
                plan, self.plan = self.plan, None
                restart = plan is not None or self.camera_changed or self.config_changed
                camera, config = self.camera, self.config
                self.camera_changed = self.config_changed = False
                max_passes = self.max_passes
                request = self.request
            if camera is None or config is None:
                continue  # the first draw brings the camera
            try:
                if plan is not None or scene is None:
                    scene = self._apply(plan, scene, N)
                if restart or session is None:
                    steps = dividers(camera["width"], camera["height"])
                    session = None
                if session is None or (self.divider > 1 and session.stats["passes"] >= 1):
                    divider = steps.pop(0) if steps else 1
                    session = self._start(N, scene, camera, config, divider)
                    with self.lock:
                        if self.stopped or self.plan is not None or self.camera_changed or self.config_changed:
                            continue  # changed while it started: begin again
                        self.native, self.busy = session, True
                session.iterate()
                if session.cancelled or session.stale:
                    session = None
                    continue
                self._publish(session, request, max_passes)
            except Exception as e:  # SceneError, ParamError, a native failure: one line in the view
                session = None
                with self.lock:
                    self.error = f"gradphoton: {e}"
                    self.busy = False
                    self.native = None
                self._tag_redraw()

    def _apply(self, plan, scene, N):
        if plan is None:
            plan = sync.Plan(rebuild=self.sync.exported)
        try:
            return sync.apply(plan, scene, N)
        except ValueError:
            if plan.rebuild is not None or plan.exported is None:
                raise
            return sync.apply(sync.Plan(rebuild=plan.exported), None, N)  # e.g. a material is gone

    def _start(self, N, scene, camera, config, divider):
        cam = dict(camera, width=max(1, math.ceil(camera["width"] / divider)),
                   height=max(1, math.ceil(camera["height"] / divider)))
        self.placement = None
        if "crop" in camera:  # only the region's pixels are traced (the camera's crop window)
            crop, rw, rh = scaled_crop(camera["crop"], camera["width"], camera["height"], divider)
            cam["crop"] = crop
            x, y, cw, ch = crop
            self.placement = (x / rw, (rh - y - ch) / rh, cw / rw, ch / rh)
        import json
        scene.set_camera(json.dumps(cam))
        method, params = config
        s = N.Session(scene, method, params)
        s.set_aux_passes(False)
        self.divider = divider
        return s

    def _publish(self, session, request, max_passes):
        images = session.develop(display=True)  # a gradient method: L2, not L1's slow solve
        rgb = images["combined"]
        h, w = rgb.shape[:2]
        out = np.empty((h, w, 4), np.float32)
        out[..., :3] = rgb[::-1]
        # The core writes alpha with a transparent film or a holdout in the scene (Session.passes).
        alpha = images.get("alpha") if "alpha" in session.passes else None
        out[..., 3] = alpha[::-1, :, 0] if alpha is not None else 1.0
        np.nan_to_num(out, copy=False, nan=0.0, posinf=0.0, neginf=0.0)  # never drawn
        stats = session.stats
        n = stats["passes"]
        done = self.divider == 1 and max_passes > 0 and n >= max_passes
        with self.lock:
            self.serial += 1
            self.image = (self.serial, out, self.placement)
            self.passes = n
            self.pass_seconds = stats.get("seconds", 0.0) / max(1, n)
            self.busy = not done
            if done:
                self.native = None
            now = time.perf_counter()
            if request is not None and self.request is request:
                self.events.append((request[0], now - request[1]))
                self.request = None
                self._full = request
            if self.divider == 1 and self._full is not None:
                self.events.append((self._full[0] + " (full resolution)", now - self._full[1]))
                self._full = None
            self.status = (f"Pass {n}" + (f" / {max_passes}" if max_passes > 0 else "") +
                           (f" | {w}x{h} (1/{self.divider})" if self.divider > 1 else "") +
                           (" | done" if done else ""))
        if not self._tag_redraw():
            with self.lock:
                self.stopped = True


def _redraw_poller(session):
    """A timer (Blender's main thread) that passes the worker's redraw requests on to the engine
    (RenderEngine.tag_redraw), until the session stops or the engine is gone. Calls into Blender
    from the worker thread are what this avoids."""
    ref = weakref.ref(session)

    def poll():
        vp = ref()
        if vp is None or vp.stopped:
            return None
        if vp.redraw_wanted:
            vp.redraw_wanted = False
            engine = vp._engine()
            if engine is None:
                return None
            try:
                engine.tag_redraw()
            except ReferenceError:  # Blender freed the engine
                return None
        return REDRAW_POLL
    return poll


# ---- engine.py's delegations ----

def view_update(engine, context, depsgraph):
    if engine.viewport is None:
        engine.viewport = ViewportSession(engine)
    engine.viewport.view_update(context, depsgraph)


def view_draw(engine, context, depsgraph):
    if engine.viewport is not None:
        engine.viewport.view_draw(engine, context, depsgraph)


def free(engine):
    """From the engine's __del__: stop the viewport's worker (never raises)."""
    try:
        vp = engine.__dict__.get("viewport")
    except (ReferenceError, AttributeError):
        return
    if vp is not None:
        vp.free()
