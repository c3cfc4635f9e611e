"""Motion blur as Cycles 3.4 samples it, for final renders (F12, `blender -b ... -f/-a`, Export
Scene). The viewport passes no frame_set and gets no motion, as Cycles' viewport.

Cycles' rules (intern/cycles/blender/util.h object_motion_steps / object_use_deform_motion,
object.cpp sync_object_motion_init, sync.cpp sync_motion, mesh.cpp sync_mesh_motion):
  - Render > Motion Blur and the view layer's Use Motion Blur turn it on; Shutter is in frames.
  - Position: the shutter covers [frame - s/2, frame + s/2] (Center), [frame, frame + s] (Start)
    or [frame - s, frame] (End).
  - Object > Motion Blur: an object with Steps n is sampled at S = 2^n + 1 evenly spaced times
    over the shutter (n = 1: 3 samples), at relative times 2i/(S-1) - 1 in [-1, 1]; an instance
    takes its instancer's switch too and the larger of the two Steps. Off: no motion at all.
  - Deformation (on by default): the mesh is read again at each time, for objects whose
    modifiers or shape keys may deform it (Object.is_deform_modified, Cycles' own test); a
    different vertex count (here: different triangles or corners too) means no deformation blur
    for that object, with a warning.
  - Camera: its own object's Motion Blur switch and Steps.
  - An object whose samples are all equal has no motion (Cycles' Object::update_motion), so a
    static scene exports exactly as without motion blur.
The result follows docs/scene-format.md "Motion blur": S samples at t = i/(S-1), t in [0, 1]
over the shutter; `matrices` / `positions` stay the frame's own.

Lights: Cycles 3.4 does not blur them (a moving spot renders the same with Motion Blur on and
off: measured, tests/blender/test_motion_blur.py), and neither do we by default. With Scene >
gradphoton > Blur Moving Lights (motion_blur_lights) a lamp is sampled as an object (its Steps:
Cycles shows no Motion Blur panel for lights, so the defaults, 3 samples): a point, spot or sun
light gets "motion", the lamp's matrices over the shutter (its position and direction keys
dropped: the origin and -Z of its own space, as Blender's lamp); an area light's surface (a
MeshRecord) gets the matrices as a mesh instance does. The shutter curve and the rolling
shutter are not rendered (one warning each, naming the setting). A method that does not render
motion blur says so itself (the core's feature_report, read from its declaration).
"""
import math

import numpy as np

# Where the shutter's centre lies from the frame, in shutters (sync.cpp's frame_center_delta).
POSITION_OFFSET = {'START': 0.5, 'CENTER': 0.0, 'END': -0.5}
MAX_STEPS = 7  # Cycles' motion_steps property range (1..7): S = 2^7 + 1 at most



def camera_lens(cam_ob):
    """What of a camera's projection may change during the shutter: focal length, sensor,
    orthographic scale and shift (None for no camera)."""
    cam = getattr(cam_ob, "data", None)
    if cam is None:
        return None
    return tuple(round(float(getattr(cam, a, 0.0)), 6)
                 for a in ("lens", "sensor_width", "sensor_height", "ortho_scale", "shift_x", "shift_y"))

class Shutter:
    """The shutter of one frame: `frame` + `subframe` is the frame's time, `length` the shutter in
    frames, `position` START / CENTER / END."""

    def __init__(self, frame, subframe, length, position):
        self.frame, self.subframe, self.length, self.position = frame, subframe, length, position

    def time(self, relative):
        """(frame, subframe) of a relative time in [-1, 1] (sync.cpp sync_motion)."""
        t = self.frame + self.subframe + (POSITION_OFFSET.get(self.position, 0.0) + 0.5 * relative) * self.length
        f = math.floor(t)
        return f, t - f


def _cycles(idb):
    """Cycles' settings of an ID, read from the original (what the user set: an evaluated copy
    may not have been updated yet when only a setting changed)."""
    return getattr(getattr(idb, "original", idb), "cycles", None)


def scene_shutter(scene, view_layer, warnings):
    """The Shutter of the scene's current frame, or None when motion blur is off (Render >
    Motion Blur, the view layer's switch, a shutter of 0). Warns once for a shutter curve that is
    not flat and for a rolling shutter, which are not rendered."""
    r = scene.render
    if not r.use_motion_blur or (view_layer is not None and not view_layer.use_motion_blur):
        return None
    if r.motion_blur_shutter <= 0:
        return None
    c = _cycles(scene)
    if not shutter_curve_is_flat(r.motion_blur_shutter_curve):
        warnings.add("motion blur Shutter Curve not rendered (the shutter opens fully at once: a flat curve)",
                     scene.name)
    if c is not None and getattr(c, "rolling_shutter_type", 'NONE') != 'NONE':
        warnings.add("motion blur Rolling Shutter not rendered (every row sees the whole shutter)", scene.name)
    position = getattr(c, "motion_blur_position", 'CENTER') if c is not None else 'CENTER'
    return Shutter(scene.frame_current, scene.frame_subframe, r.motion_blur_shutter, position)


def shutter_curve_is_flat(curve):
    """Whether Render > Motion Blur > Shutter Curve weighs every time alike (Blender's default):
    Cycles samples times in proportion to the curve (camera.cpp, shutter_table)."""
    try:
        curve.initialize()
        cm = curve.curves[0]
        ys = [curve.evaluate(cm, i / 32.0) for i in range(33)]
    except (AttributeError, IndexError, RuntimeError, TypeError):
        return True
    return max(ys) - min(ys) <= 1e-4 * max(1e-6, max(abs(y) for y in ys))


def object_steps(parent, ob):
    """Cycles' object_motion_steps (util.h): 0 when the object (or, for an instance, its
    instancer) has Motion Blur off, else 2^Steps + 1 samples, Steps the larger of the two."""
    c = _cycles(ob)
    if c is not None and not c.use_motion_blur:
        return 0
    steps = max(1, c.motion_steps if c is not None else 1)
    if parent is not None and parent != ob:
        pc = _cycles(parent)
        if pc is not None:
            if not pc.use_motion_blur:
                return 0
            steps = max(steps, pc.motion_steps)
    return (2 << (min(steps, MAX_STEPS) - 1)) + 1


def use_deform(parent, ob):
    """Cycles' object_use_deform_motion (util.h): the object's Deformation switch and, for an
    instance, its instancer's."""
    c = _cycles(ob)
    use = c.use_deform_motion if c is not None else True
    if use and parent is not None and parent != ob:
        pc = _cycles(parent)
        use = pc.use_deform_motion if pc is not None else True
    return use


def relative_times(steps):
    """Cycles' Object::motion_time: step i of S at 2i/(S-1) - 1."""
    return [2.0 * i / (steps - 1) - 1.0 for i in range(steps)]


def instance_key(inst):
    """What identifies one depsgraph instance across evaluations at other times (Cycles'
    ObjectKey: parent, persistent id, object). No pointer: they change between evaluations."""
    if inst.is_instance:
        return (inst.object.name, inst.parent.name, tuple(inst.persistent_id))
    return (inst.object.name, "", ())


class MotionSampler:
    """Collects, during the frame's export, what needs samples over the shutter; sample() then
    evaluates the scene at each time (frame_set), reads them, and restores the frame."""

    def __init__(self, shutter, frame_set, scene):
        self.shutter = shutter
        self.frame_set = frame_set
        self.scene = scene
        self.instances = {}   # instance key -> (steps, [(record, index)]): object-to-world matrices
        self.deforming = {}   # object name -> (steps, record, needs_uvs): positions per step
        self.lights = {}      # instance key -> (steps, frame matrix, name, the light's dict or MeshRecord)
        self.camera_steps = 0
        self.camera_frame = None  # the camera's 16 numbers at the frame
        self.camera_name = None
        self.camera_lens_frame = None  # its lens at the frame (camera_lens)
        self.camera_lens = {}  # relative time -> camera_lens there
        self.times = set()
        # results
        self.matrices = {}    # instance key -> {relative time: (4,4) float32}
        self.positions = {}   # object name -> {relative time: (positions, indices) or None}
        self.camera = {}      # relative time -> 16 numbers

    # ---- registration (the frame's export) ----
    def add_instance(self, inst, record, index):
        ob = inst.object
        parent = inst.parent if inst.is_instance else None
        steps = object_steps(parent, ob)
        if steps == 0:
            return
        key = instance_key(inst)
        self.instances.setdefault(key, (steps, []))[1].append((record, index))
        self.times.update(relative_times(steps))
        if use_deform(parent, ob) and ob.name not in self.deforming and record.deform_source is None:
            try:
                deforms = ob.original.is_deform_modified(self.scene, 'RENDER')
            except (AttributeError, ReferenceError, TypeError):
                deforms = False
            if deforms:
                self.deforming[ob.name] = (steps, record, record.needs_uvs)
                record.deform_source = ob.name

    def add_light(self, inst, matrix, target):
        """`target`: what export/light.py added (a light's dict, or an area light's MeshRecord)."""
        parent = inst.parent if inst.is_instance else None
        steps = object_steps(parent, inst.object)
        if steps:
            self.lights[instance_key(inst)] = (steps, matrix, inst.object.name, target)
            self.times.update(relative_times(steps))

    def add_camera(self, cam_ob, frame_matrix):
        self.camera_steps = object_steps(None, cam_ob) if cam_ob is not None else 0
        self.camera_frame = frame_matrix
        self.camera_name = cam_ob.name if cam_ob is not None else None
        self.camera_lens_frame = camera_lens(cam_ob)
        if self.camera_steps:
            self.times.update(relative_times(self.camera_steps))

    # ---- sampling ----
    def sample(self, depsgraph, read_mesh, camera_matrix):
        """Evaluates the scene at every time needed and reads the matrices, deformed positions and
        camera there; the frame is restored afterwards, also on error. `read_mesh(ob,
        needs_uvs)` -> (positions, indices) of an evaluated object; `camera_matrix(ob)` -> 16
        numbers."""
        if not self.times:
            return
        wanted = set(self.instances) | set(self.lights)
        # Centred on the frame, time 0 is the frame itself, already read (Cycles skips it too).
        centred = POSITION_OFFSET.get(self.shutter.position, 0.0) == 0.0
        try:
            for rel in sorted(t for t in self.times if not (centred and t == 0.0)):
                frame, subframe = self.shutter.time(rel)
                self.frame_set(frame, subframe)
                for inst in depsgraph.object_instances:
                    if inst.is_instance and not inst.show_self:
                        continue
                    key = instance_key(inst)
                    if key in wanted:
                        self.matrices.setdefault(key, {})[rel] = np.array(inst.matrix_world, dtype=np.float32)
                    name = inst.object.name
                    if name in self.deforming:
                        seen = self.positions.setdefault(name, {})
                        if rel not in seen:
                            seen[rel] = read_mesh(inst.object, self.deforming[name][2])
                cam = depsgraph.scene.camera
                if self.camera_steps and cam is not None:
                    self.camera[rel] = camera_matrix(cam.evaluated_get(depsgraph))
                    self.camera_lens[rel] = camera_lens(cam.evaluated_get(depsgraph))
        finally:
            self.frame_set(self.shutter.frame, self.shutter.subframe)

    # ---- results ----
    def apply(self, records, description, warnings):
        """Writes the samples into the records (record.motion: (K,S,4,4) or None, split by S
        where a record's instances differ in steps; record.motion_positions: (S',N,3) or None)
        and the camera's "motion"; returns the records (split ones added) and the names of the
        objects that move."""
        moving = {}  # names, in order (a dict as an ordered set)
        per_record = {}  # id(record) -> {index: (S,4,4)}
        for key, (steps, slots) in self.instances.items():
            seen = self.matrices.get(key, {})
            for record, index in slots:
                frame_m = record.matrices[index]
                ms = np.stack([seen.get(rel, frame_m) for rel in relative_times(steps)]).astype(np.float32)
                if not (ms == ms[0]).all():
                    per_record.setdefault(id(record), {})[index] = ms
                    moving.setdefault(record.name)  # by object: thousands of particles are one name
        out = []
        for rec in records:
            motions = per_record.get(id(rec))
            if rec.deform_source is not None:
                self._deformation(rec, warnings, moving)
            if not motions:
                out.append(rec)
                continue
            out.extend(_split_by_steps(rec, motions))
        for key, (steps, frame_m, name, target) in self.lights.items():
            seen = self.matrices.get(key, {})
            if not any(not np.allclose(m, frame_m, rtol=0, atol=1e-6) for m in seen.values()):
                continue
            ms = np.stack([seen.get(rel, frame_m) for rel in relative_times(steps)]).astype(np.float32)
            if isinstance(target, dict):  # point, spot, sun: placed by the matrices alone
                target.pop("position", None)
                target.pop("direction", None)
                target["motion"] = [{"matrix": m.reshape(16).tolist()} for m in ms]
            else:  # an area light's surface: one instance, moving as a mesh's
                target.motion = ms[None]
            moving.setdefault(name)
        if self.camera_steps and description.get("camera") is not None:
            frames = [self.camera.get(rel, self.camera_frame) for rel in relative_times(self.camera_steps)]
            if any(f != frames[0] for f in frames):
                description["camera"]["motion"] = [list(map(float, f)) for f in frames]
                moving.setdefault("camera")
            # Cycles blurs a zoom too (camera.cpp's fov_pre / fov_post); the core takes the frame's
            # lens for the whole shutter: said once, naming the camera.
            if any(lens != self.camera_lens_frame for lens in self.camera_lens.values()):
                warnings.add("camera lens changing during the shutter not blurred (the frame's lens is used)",
                             self.camera_name)
        return out, list(moving)

    def _deformation(self, rec, warnings, moving):
        name = rec.deform_source
        steps = self.deforming[name][0]
        seen = self.positions.get(name, {})
        steps_pos = []
        for rel in relative_times(steps):
            got = seen.get(rel, (rec.positions, rec.indices) if rel == 0.0 else None)  # 0: the frame (centred)
            if got is None:
                return  # not met at that time (hidden): no deformation blur
            pos, idx = got
            if pos.shape != rec.positions.shape or idx.shape != rec.indices.shape or not np.array_equal(idx, rec.indices):
                # Cycles' "Topology differs, disabling motion blur for object" (mesh.cpp).
                warnings.add("topology changes during the shutter (no deformation blur)", name)
                return
            steps_pos.append(pos)
        arr = np.stack(steps_pos).astype(np.float32)
        if not (arr == arr[0]).all():
            rec.motion_positions = arr
            moving.setdefault(name)


def _split_by_steps(rec, motions):
    """`rec` with record.motion set: one record per sample count among its moving instances (the
    core takes one S per mesh); static instances stay in the first, as S equal matrices."""
    by_steps = {}
    for index, ms in sorted(motions.items()):
        by_steps.setdefault(len(ms), []).append(index)
    groups = sorted(by_steps.items())
    first_steps = groups[0][0]
    moving_elsewhere = {i for s, idx in groups[1:] for i in idx}
    out = []
    keep = [i for i in range(len(rec.matrices)) if i not in moving_elsewhere]
    out.append(_subrecord(rec, keep, motions, first_steps))
    for steps, idx in groups[1:]:
        out.append(_subrecord(rec, idx, motions, steps))
    return out


def _subrecord(rec, indices, motions, steps):
    sub = rec if len(indices) == len(rec.matrices) else rec.copy_without_instances()
    matrices = [rec.matrices[i] for i in indices]
    names = [rec.instance_names[i] for i in indices]
    sub.matrices, sub.instance_names = matrices, names
    if rec.instance_random_ids:
        sub.instance_random_ids = [rec.instance_random_ids[i] for i in indices]
    sub.motion = np.stack([motions[i] if i in motions else np.repeat(rec.matrices[i][None], steps, axis=0)
                           for i in indices]).astype(np.float32)
    return sub

