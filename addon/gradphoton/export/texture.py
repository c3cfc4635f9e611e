"""Image files for Image Texture nodes (export/nodes.py writes the nodes themselves).

The core reads each file once (OpenImageIO) and converts it to scene-linear through Blender's
own OpenColorIO config, from the colour space Blender marks the image with. Image files: the
image's own path (relative paths resolved as Blender does, libraries too); packed images are
written once to a temporary folder by content; generated or edited-only images are written
there from their pixels. A missing image is one warning in Blender's report and renders
magenta, as Cycles does (export/nodes.py).
"""
import hashlib
import os
import tempfile

import numpy as np

_FILE_EXT = {'PNG': ".png", 'JPEG': ".jpg", 'OPEN_EXR': ".exr", 'OPEN_EXR_MULTILAYER': ".exr", 'TARGA': ".tga",
             'TARGA_RAW': ".tga", 'TIFF': ".tif", 'BMP': ".bmp", 'HDR': ".hdr", 'WEBP': ".webp"}


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
