"""Textures: Blender's Image Texture, Normal Map, Bump, Mapping and Texture Coordinate nodes ->
the core's texture references (docs/scene-format.md, "Textures").

A material input linked to an image becomes {"texture": <absolute file>, "colorspace": <as
Blender marks the image>, ...}; the core reads each file once (OpenImageIO) and converts it
to scene-linear through Blender's own OpenColorIO config. What is followed from an input:

  - Image Texture (Color or Alpha output), flat projection; Repeat, Extend and Clip extension
    (Mirror is read as Repeat); Linear or Closest interpolation (Cubic and Smart as Linear);
  - optionally a Separate RGB / Separate Color node in between (one channel of the image);
  - its Vector input: unlinked (the active render UV map), a Texture Coordinate UV output or a
    UV Map node of that map, through a Mapping node (2D part: location, Z rotation, scale);
  - Normal inputs: a Normal Map node (tangent space, strength) and a Bump node (height from an
    image, strength, distance, invert), the Bump's own Normal from a Normal Map.

Image files: the image's own path (relative paths resolved as Blender does, libraries too);
packed images are written once to a temporary folder by content; generated or edited-only
images are written there from their pixels. A missing image is one warning in Blender's
report and renders magenta, as Cycles does. Anything else feeding an input is a counted
warning, and the input takes its own value.
"""
import hashlib
import math
import os
import tempfile

import numpy as np

MAGENTA = [1.0, 0.0, 1.0]
_EXTENSION = {'REPEAT': "repeat", 'EXTEND': "extend", 'CLIP': "clip", 'MIRROR': "repeat"}
_FILE_EXT = {'PNG': ".png", 'JPEG': ".jpg", 'OPEN_EXR': ".exr", 'OPEN_EXR_MULTILAYER': ".exr", 'TARGA': ".tga",
             'TARGA_RAW': ".tga", 'TIFF': ".tif", 'BMP': ".bmp", 'HDR': ".hdr", 'WEBP': ".webp"}
_SEPARATE = {'ShaderNodeSeparateRGB': {"R": "r", "G": "g", "B": "b"},
             'ShaderNodeSeparateColor': {"Red": "r", "Green": "g", "Blue": "b"}}


def _cache_dir():
    d = os.path.join(tempfile.gettempdir(), "gradphoton-images")
    os.makedirs(d, exist_ok=True)
    return d


def _write_once(data, ext):
    """Writes bytes to the image cache under their hash (once); returns the path."""
    path = os.path.join(_cache_dir(), hashlib.sha1(data).hexdigest() + ext)
    if not os.path.exists(path):
        tmp = path + f".{os.getpid()}.tmp"
        with open(tmp, "wb") as f:
            f.write(data)
        os.replace(tmp, path)
    return path


def _pixels_as_pfm(image):
    """An image's pixels (bottom row first, as PFM stores them) as PFM bytes."""
    w, h = image.size
    px = np.empty(w * h * image.channels, np.float32)
    image.pixels.foreach_get(px)
    px = px.reshape(h, w, image.channels)
    rgb = px[..., :3] if image.channels >= 3 else np.repeat(px[..., :1], 3, axis=2)
    return f"PF\n{w} {h}\n-1.0\n".encode() + np.ascontiguousarray(rgb, dtype="<f4").tobytes()


def image_file(image):
    """(path, None) of a file the core can read for `image`, or (None, reason) when it has none."""
    import bpy
    if image is None:
        return None, "no image"
    if image.source in {'SEQUENCE', 'MOVIE', 'TILED'}:
        return None, f"{image.source.lower()} images unsupported"
    if image.packed_file is not None:
        name = image.filepath_raw or image.name
        ext = os.path.splitext(name)[1].lower() or _FILE_EXT.get(image.file_format, ".png")
        return _write_once(bytes(image.packed_file.data), ext), None
    if image.source == 'GENERATED' or image.is_dirty:
        if image.size[0] == 0 or not image.has_data and image.source != 'GENERATED':
            return None, "no pixels"
        return _write_once(_pixels_as_pfm(image), ".pfm"), None
    path = os.path.normpath(bpy.path.abspath(image.filepath, library=image.library))
    if not os.path.isfile(path):
        return None, f"file not found: {path}"
    return path, None


def _from(socket):
    """(node, output socket) feeding an input socket, through reroutes; (None, None) if unlinked."""
    if not socket.is_linked:
        return None, None
    link = socket.links[0]
    node, out = link.from_node, link.from_socket
    while node.bl_idname == 'NodeReroute':
        if not node.inputs[0].is_linked:
            return None, None
        link = node.inputs[0].links[0]
        node, out = link.from_node, link.from_socket
    return node, out


def _mapping_matrix(node):
    """The 2D affine part of a Mapping node (uv' = M uv + t) as [[a, b, tx], [c, d, ty]], or None
    when its inputs are linked or its type has no such form."""
    ins = node.inputs
    if any(ins[n].is_linked for n in ("Location", "Rotation", "Scale") if n in ins):
        return None
    loc, rot, scale = ins["Location"].default_value, ins["Rotation"].default_value, ins["Scale"].default_value
    if node.vector_type not in {'POINT', 'TEXTURE'} or abs(rot[0]) > 1e-6 or abs(rot[1]) > 1e-6:
        return None
    c, s = math.cos(rot[2]), math.sin(rot[2])
    # POINT: R (S uv) + L. TEXTURE: the inverse, S^-1 R^-1 (uv - L).
    if node.vector_type == 'POINT':
        return [[c * scale[0], -s * scale[1], loc[0]], [s * scale[0], c * scale[1], loc[1]]]
    if scale[0] == 0 or scale[1] == 0:
        return None
    a, b = c / scale[0], s / scale[0]
    d, e = -s / scale[1], c / scale[1]
    return [[a, b, -(a * loc[0] + b * loc[1])], [d, e, -(d * loc[0] + e * loc[1])]]


class TextureReader:
    """Texture references for one material export (shares the exporter's Warnings)."""

    def __init__(self, warnings):
        self.w = warnings
        self.used = False  # a texture was referenced: the meshes need their UVs

    # ---- images ----

    def _image_ref(self, node, out, mat, scalar):
        """The texture dict of an Image Texture node's output, or a magenta constant."""
        if node.projection != 'FLAT':
            self.w.add("image projection other than Flat read as Flat", f"'{mat.name}': {node.name}")
        path, why = image_file(node.image)
        if path is None:
            label = node.image.name if node.image is not None else node.name
            self.w.add("image texture missing (magenta)", f"'{mat.name}': {label} ({why})")
            return 0.2126 + 0.0722 if scalar else list(MAGENTA)
        self.used = True
        ref = {"texture": path, "colorspace": node.image.colorspace_settings.name,
               "wrap": _EXTENSION.get(node.extension, "repeat")}
        if node.extension == 'MIRROR':
            self.w.add("image extension Mirror read as Repeat", f"'{mat.name}': {node.name}")
        if node.interpolation == 'Closest':
            ref["interpolation"] = "closest"
        if out.name == "Alpha":
            ref["channel"] = "a"
        elif scalar:
            ref["channel"] = "luminance"
        vec_node, vec_out = _from(node.inputs["Vector"])
        if vec_node is not None:
            matrix = self._uv_of(vec_node, vec_out, mat)
            if matrix is not None:
                ref["mapping"] = matrix
        return ref

    def _uv_of(self, node, out, mat):
        """A Vector input's uv transform (None: plain UV) from Mapping / Texture Coordinate nodes."""
        matrix = None
        if node.bl_idname == 'ShaderNodeMapping':
            matrix = _mapping_matrix(node)
            if matrix is None:
                self.w.add("Mapping node not a 2D point/texture mapping (ignored)", f"'{mat.name}': {node.name}")
            node, out = _from(node.inputs["Vector"])
            if node is None:  # (Cycles would map the point (0, 0, 0): a constant texel; rare)
                return matrix
        if node.bl_idname == 'ShaderNodeTexCoord' and out.name == "UV":
            return matrix
        if node.bl_idname == 'ShaderNodeUVMap':
            if node.uv_map:
                self.w.add("UV Map node read as the active render UV map", f"'{mat.name}': {node.name}")
            return matrix
        self.w.add("texture coordinates other than UV read as UV", f"'{mat.name}': {node.name}")
        return matrix

    # ---- inputs ----

    def value(self, socket, mat, scalar, square=False):
        """A material input: its constant, or a texture dict when an image drives it.
        Scalar inputs read the luminance of a Color output (Blender's conversion)."""
        node, out = _from(socket)
        if node is None:
            return None
        channel = None
        if node.bl_idname in _SEPARATE and out.name in _SEPARATE[node.bl_idname]:
            channel = _SEPARATE[node.bl_idname][out.name]
            node, out = _from(node.inputs[0])
            if node is None:
                return None
        if node.bl_idname != 'ShaderNodeTexImage':
            return None
        ref = self._image_ref(node, out, mat, scalar or channel is not None)
        if isinstance(ref, dict):
            if channel is not None:
                ref["channel"] = channel
            if square:
                ref["square"] = True
        elif square:
            ref = ref * ref
        return ref

    def normal(self, socket, mat):
        """{"normal_map": ..., "bump": ...} for a Normal input (empty when unlinked)."""
        node, _ = _from(socket)
        out = {}
        if node is None:
            return out
        if node.bl_idname == 'ShaderNodeBump':
            height = self.value(node.inputs["Height"], mat, scalar=True)
            if isinstance(height, dict):
                dist = node.inputs["Distance"].default_value * (-1.0 if node.invert else 1.0)
                out["bump"] = dict(height, strength=max(0.0, node.inputs["Strength"].default_value), distance=dist)
            elif node.inputs["Height"].is_linked:
                self.w.add("Bump height not from an image (ignored)", f"'{mat.name}': {node.name}")
            inner, _ = _from(node.inputs["Normal"])
            if inner is not None:
                out.update(self.normal(node.inputs["Normal"], mat))
            return out
        if node.bl_idname == 'ShaderNodeNormalMap':
            if node.space != 'TANGENT':
                self.w.add("Normal Map space other than Tangent (ignored)", f"'{mat.name}': {node.name}")
                return out
            if node.uv_map:
                self.w.add("Normal Map UV map read as the active render UV map", f"'{mat.name}': {node.name}")
            color = self.value(node.inputs["Color"], mat, scalar=False)
            if isinstance(color, dict):
                out["normal_map"] = dict(color, strength=max(0.0, node.inputs["Strength"].default_value))
            elif node.inputs["Color"].is_linked:
                self.w.add("Normal Map colour not from an image (ignored)", f"'{mat.name}': {node.name}")
            return out
        self.w.add("Normal input not from a Normal Map or Bump node (ignored)", f"'{mat.name}': {node.name}")
        return out
