"""Camera: Blender's scene camera -> the core's camera (same conventions: -Z view, +Y up, field
of view on the fitted axis). Resolution with percentage; border as the core's crop window (only
its pixels are traced); depth of field as Cycles: aperture radius = focal length / (2 f-stop),
focus distance from the focus object (along the view axis) or the distance field; lens shift and
orthographic cameras as Blender's; Clip Start / End as Cycles clips camera rays; Film > Pixel Filter (box, Gaussian, Blackman-Harris and its width)
as Cycles' settings say. Panoramic cameras are approximated (a counted warning)."""
import math

import numpy as np


def resolution(render):
    s = render.resolution_percentage / 100.0
    return max(1, int(render.resolution_x * s)), max(1, int(render.resolution_y * s))


# Film > Pixel Filter (Cycles' settings, scene.cycles) -> the core's camera "pixel_filter".
PIXEL_FILTERS = {'BOX': "box", 'GAUSSIAN': "gaussian", 'BLACKMAN_HARRIS': "blackman-harris"}


def pixel_filter(scene):
    """The scene's Film > Pixel Filter as Cycles renders it; Blender's default (Blackman-Harris,
    1.5 px) where Cycles' settings are absent."""
    c = getattr(scene, "cycles", None)
    kind = PIXEL_FILTERS.get(getattr(c, "pixel_filter_type", 'BLACKMAN_HARRIS'), "blackman-harris")
    width = float(getattr(c, "filter_width", 1.5))
    return {"type": kind, "width": min(64.0, max(0.01, width))}


def camera_matrix(ob):
    """The camera-to-world matrix (16 numbers, row-major) of a camera object, its scale dropped:
    the core wants a rigid camera. Also each step of the camera's motion (export/motion.py)."""
    mw = ob.matrix_world
    rot = mw.to_quaternion().to_matrix()
    t = mw.translation
    return [rot[0][0], rot[0][1], rot[0][2], t[0], rot[1][0], rot[1][1], rot[1][2], t[1],
            rot[2][0], rot[2][1], rot[2][2], t[2], 0, 0, 0, 1]


def export_camera(scene, warnings):
    render = scene.render
    width, height = resolution(render)
    border = None
    if render.use_border:
        x0, x1 = int(render.border_min_x * width), int(render.border_max_x * width)
        y0, y1 = int(render.border_min_y * height), int(render.border_max_y * height)
        if x1 > x0 and y1 > y0 and (x1 - x0, y1 - y0) != (width, height):
            border = (x0, y0, x1 - x0, y1 - y0)
    ob = scene.camera
    d = {"width": width, "height": height, "pixel_filter": pixel_filter(scene)}
    if border is not None:  # the core traces only these pixels (its rows run from the top)
        x0, y0, w, h = border
        d["crop"] = [x0, height - (y0 + h), w, h]
    if ob is None:
        warnings.add("no scene camera (default view)", scene.name)
        d["matrix"] = [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 5, 0, 0, 0, 1]
        return d, width, height, border
    cam = ob.data
    mw = ob.matrix_world
    t = mw.translation
    d["matrix"] = camera_matrix(ob)
    if cam.type == 'ORTHO':
        d["type"] = "orthographic"
        d["ortho_scale"] = cam.ortho_scale
    elif cam.type != 'PERSP':
        warnings.add("panoramic camera (rendered as perspective)", f"{ob.name} ({cam.type})")
    # Clip Start / End: Cycles starts camera rays on the near clip plane (nothing nearer is seen,
    # no fog in front of it) and ends them on the far one (kernel/camera/camera.h).
    d["clip_start"] = float(cam.clip_start)
    if cam.clip_end > cam.clip_start:
        d["clip_end"] = float(cam.clip_end)
    if cam.shift_x != 0 or cam.shift_y != 0:
        d["shift"] = [cam.shift_x, cam.shift_y]
    fit = cam.sensor_fit
    sensor = cam.sensor_height if fit == 'VERTICAL' else cam.sensor_width
    d["fov"] = math.degrees(2.0 * math.atan(0.5 * sensor / cam.lens))
    d["sensor_fit"] = {'AUTO': "auto", 'HORIZONTAL': "horizontal", 'VERTICAL': "vertical"}[fit]
    if cam.dof.use_dof and cam.dof.aperture_fstop > 0:
        d["aperture_radius"] = 0.5 * cam.lens * 1e-3 / cam.dof.aperture_fstop
        focus = cam.dof.focus_distance
        if cam.dof.focus_object is not None:
            fo = cam.dof.focus_object.matrix_world.translation
            view = -np.array([mw[0][2], mw[1][2], mw[2][2]])
            view /= np.linalg.norm(view)
            focus = float(np.dot(np.array(fo - t), view))
        d["focus_distance"] = max(1e-4, focus)
    return d, width, height, border
