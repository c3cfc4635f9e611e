"""Lights: Blender's watts -> the core's radiometric units, following Cycles 3.4 so that a scene
lit by these renders equally bright in both (tested against Cycles in tests/blender):

  point, spot  power P [W]      -> intensity I = P color / (4 pi)  W/sr   ("power" key)
               radius r         -> a disk of radius r facing the shading point ("radius")
  sun          strength S       -> irradiance E = S color           W/m^2  ("strength" key)
               angle a          -> directions in a cone of half-angle a/2 ("angle")
  area         power P [W]      -> one-sided emissive quad/disk/ellipse facing the light's -Z,
                                   radiance L = P color / (4 A)     W/(sr m^2)
               (Cycles: eval_fac = 0.25 * invarea for area lights; A in world units, so the
               object's scale changes the area as in Cycles)

Cycles' lights are not geometry: rays pass through them (a hit adds the light's emission and
the path goes on) and they cast no shadow. An area light is therefore an emissive dielectric
of IOR 1 (a pass-through surface) with casts_shadow off, and shown to camera rays only when the
object's Visibility > Camera is on (off by default for light objects in Blender 3.4); its
Diffuse/Glossy/Transmission switches become keys of that surface or of a point/spot/sun light
(export/visibility.py). Point,
spot and sun lights are never hit by rays (next-event estimation only, as the core's delta
lights): shown to the camera or in a mirror they are a counted warning. Area-light spread is
not modelled (a counted warning).

Motion blur (export/motion.py): a moving point, spot or sun light gets "motion", its matrices
over the shutter placing its origin and -Z (docs/scene-format.md "Motion blur"); a moving area
light's surface moves as a mesh does (its radiance stays the frame's, from the frame's area).
"""
import math

import numpy as np

from . import visibility

DISK_SEGMENTS = 64


def _dir(m):  # the light's -Z axis in world space
    d = -np.array([m[0][2], m[1][2], m[2][2]], dtype=np.float64)
    return (d / np.linalg.norm(d)).tolist()


def _pos(m):
    return [m[0][3], m[1][3], m[2][3]]


def add_light(out, inst, mats, warnings):
    """Adds the light; returns what it added (the light's dict, or an area light's MeshRecord),
    which motion blur moves (export/motion.py), or None."""
    ob = inst.object
    la = ob.data
    m = np.array(inst.matrix_world, dtype=np.float64)
    name = ob.name if not inst.is_instance else f"{ob.name} [{inst.random_id & 0xffff}]"
    color = [la.color[0], la.color[1], la.color[2]]
    visibility.check_light(ob, la, warnings)
    flags = visibility.lobe_flags(ob, warnings)
    if la.type in {'POINT', 'SPOT'}:
        d = {"type": la.type.lower(), "name": name, "position": _pos(m), "power": max(0.0, la.energy), "color": color,
             "radius": max(0.0, la.shadow_soft_size), **flags}
        if la.type == 'SPOT':
            d.update({"direction": _dir(m), "spot_size": min(180.0, math.degrees(la.spot_size)),
                      "spot_blend": min(1.0, max(0.0, la.spot_blend))})
        out.description["lights"].append(d)
        return d
    if la.type == 'SUN':
        d = {"type": "sun", "name": name, "direction": _dir(m), "strength": max(0.0, la.energy), "color": color,
             "angle": min(179.0, math.degrees(la.angle)), **flags}
        out.description["lights"].append(d)
        return d
    if la.type == 'AREA':
        return _add_area(out, ob, la, m, name, color, warnings, flags)
    warnings.add("unsupported light type", f"{ob.name} ({la.type})")
    return None


def _add_area(out, ob, la, m, name, color, warnings, flags):
    from .mesh import MeshRecord
    sx = la.size
    sy = la.size_y if la.shape in {'RECTANGLE', 'ELLIPSE'} else la.size
    if sx <= 0 or sy <= 0:
        return None
    if abs(getattr(la, "spread", math.pi) - math.pi) > 1e-4:
        warnings.add("area light Spread not modelled: the light spreads over its whole front side, as Spread 180\u00b0",
                     f"{ob.name} (Spread {math.degrees(la.spread):.0f}\u00b0)")
    if la.shape in {'SQUARE', 'RECTANGLE'}:
        # Winding such that the geometric normal is the light's local -Z (its emitting side).
        pos = np.array([[-sx / 2, -sy / 2, 0], [-sx / 2, sy / 2, 0], [sx / 2, sy / 2, 0], [sx / 2, -sy / 2, 0]],
                       np.float32)
        idx = np.array([[0, 1, 2], [0, 2, 3]], np.uint32)
        area_local = sx * sy
    else:
        a = np.linspace(0, 2 * np.pi, DISK_SEGMENTS, endpoint=False)
        # Polygon scaled to the ellipse's exact area, so the emitted power matches too.
        k = math.sqrt((2 * math.pi / DISK_SEGMENTS) / math.sin(2 * math.pi / DISK_SEGMENTS))
        ring = np.stack([0.5 * k * sx * np.cos(a), 0.5 * k * sy * np.sin(a), np.zeros_like(a)], 1)
        pos = np.vstack([[[0, 0, 0]], ring]).astype(np.float32)
        j = np.arange(DISK_SEGMENTS, dtype=np.uint32)
        idx = np.stack([np.zeros_like(j), (j + 1) % DISK_SEGMENTS + 1, j + 1], 1).astype(np.uint32)
        area_local = math.pi * sx * sy / 4  # the exact ellipse, as Cycles
    # World area: the local unit square spans |M ex x M ey|.
    scale = float(np.linalg.norm(np.cross(m[:3, 0], m[:3, 1])))
    area = area_local * scale
    if area <= 0:
        return None
    mat_name = f"__light_{name}"
    out.description["materials"][mat_name] = {
        "type": "dielectric", "ior": 1.0, "color": 1.0,  # a pass-through surface, as Cycles' lights
        "emission": color, "strength": max(0.0, la.energy) / (4.0 * area), "two_sided": False,
        "visible_to_camera": bool(ob.visible_camera), "casts_shadow": False, **flags}
    rec = MeshRecord(name)
    rec.positions, rec.indices, rec.triangle_count = pos, idx, len(idx)
    rec.materials = [mat_name]
    rec.matrices.append(m.astype(np.float32))
    rec.instance_names.append(name)
    out.meshes.append(rec)
    return rec
