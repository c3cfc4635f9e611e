"""World: the World's node tree -> the core's environment (docs/scene-format.md, "Environment"),
with World > Settings > Ray Visibility (export/visibility.py) and Sampling.

What is read, until the core's node evaluator drives the World (branch nodes-core):
  - World Output <- Background (Color x Strength, W sr^-1 m^-2 as Cycles);
  - the Background's Color from an Environment Texture (image, Linear / Closest / Cubic / Smart,
    Equirectangular / Mirror Ball): an image map the core importance-samples;
  - or from a Sky Texture (Nishita, Preetham; Hosek-Wilkie, which the core renders as Preetham
    with one warning): the core precomputes and samples it as Cycles 3.4 defines it;
  - the texture's Vector: unlinked, or a Texture Coordinate's Generated or Object output (the
    ray direction; Object through the object's inverse matrix), through Mapping nodes (Point,
    Vector, Texture, Normal: their linear part, which is how users turn an HDRI);
  - Mix Shader (its Fac a value) and Add Shader of backgrounds, nested as deep as they go: the
    core's sum of backgrounds, each weighted by its factors (Cycles adds the weighted closures);
  - a Mix Shader whose factor is Light Path "Is Camera Ray" between two such backgrounds:
    camera rays see the second, everything else is lit by the first (the core's "camera");
  - World > Settings > Sampling: Auto (the image's size) or Manual (map resolution).
Anything these shapes cannot say -- a Mix Shader's Fac linked to anything but a top-level "Is
Camera Ray", Light Path anywhere else, a linked Strength, a Color from another node, a texture
Vector through a Mapping with a location or a Texture Coordinate's Object of an object placed off
the origin (Cycles moves the direction by its translation too), Window or Camera coordinates --
exports the World's
whole tree as a graph (the core evaluates it per direction and ray, lights/world_graph.h): the
closures (Background, Mix, Add) over the node table nodes.py writes, as materials.
Anything else is one warning naming the node, and the socket's own value.
"""
import math

from . import nodes as node_graph
from . import texture, visibility, volume
from .links import linked_from as _from


_INTERPOLATION = {'Linear': "linear", 'Closest': "closest", 'Cubic': "cubic", 'Smart': "smart"}
_PROJECTION = {'EQUIRECTANGULAR': "equirectangular", 'MIRROR_BALL': "mirror_ball"}


WORLD_MEDIUM = "__world"  # the World's Volume output, as a medium of the scene format


def export_world_volume(world, warnings):
    """The World's Volume output as a medium filling the open (export/volume.py), or None."""
    if world is None or not world.use_nodes:
        return None
    socket = volume.volume_socket(world.node_tree, 'ShaderNodeOutputWorld')
    return volume.export_volume(socket, f"world '{world.name}'", warnings) if socket is not None else None


def export_world(world, warnings):
    env = _environment(world, warnings)
    if env:
        env.update(visibility.world_flags(world, warnings))
    return env


def _environment(world, warnings):
    if world is None:
        return None
    if not world.use_nodes or world.node_tree is None:
        c = world.color
        return {"color": [c[0], c[1], c[2]], "strength": 1.0}
    out = next((n for n in world.node_tree.nodes
                if n.bl_idname == 'ShaderNodeOutputWorld' and n.is_active_output), None)
    if out is None or not out.inputs["Surface"].is_linked:
        return None
    node, _ = _from(out.inputs["Surface"])
    if node is None:
        return None
    if _needs_graph(node, top=True):
        return _graph(world, out, warnings)
    if node.bl_idname == 'ShaderNodeMixShader' and _is_camera_ray(node.inputs["Fac"]):
        lit = _backgrounds(world, _from(node.inputs[1])[0], warnings)
        seen = _backgrounds(world, _from(node.inputs[2])[0], warnings)
        env = lit or {"color": [0.0, 0.0, 0.0]}
        env["camera"] = seen or {"color": [0.0, 0.0, 0.0]}
        return env
    return _backgrounds(world, node, warnings)


def _needs_graph(node, top=False):
    """Whether the closure tree under `node` needs the core's graph (see the module's note)."""
    if node is None:
        return False
    t = node.bl_idname
    if t == 'ShaderNodeAddShader':
        return any(_needs_graph(_from(node.inputs[i])[0]) for i in (0, 1))
    if t == 'ShaderNodeMixShader':
        fac = node.inputs["Fac"]
        if fac.is_linked and not (top and _is_camera_ray(fac)):
            return True
        return any(_needs_graph(_from(node.inputs[i])[0]) for i in (1, 2))
    if t != 'ShaderNodeBackground':
        return False
    if node.inputs["Strength"].is_linked:
        return True
    src, out = _from(node.inputs["Color"])
    if src is None:
        return False
    if src.bl_idname not in ('ShaderNodeTexEnvironment', 'ShaderNodeTexSky') or out.name != "Color":
        return src.bl_idname in node_graph.SUPPORTED
    return src.inputs["Vector"].enabled and not _linear_vector(src.inputs["Vector"])


def _linear_vector(socket):
    """Whether a texture's Vector is the direction through a chain the simple route writes as a
    3x3 matrix: Mapping nodes (inputs unlinked, no location on Point / Texture) over a Texture
    Coordinate's Generated or Object output, or unlinked."""
    node, out = _from(socket)
    while node is not None:
        if node.bl_idname == 'ShaderNodeMapping':
            if any(node.inputs[n].is_linked for n in ("Location", "Rotation", "Scale")):
                return False
            if node.vector_type in ('POINT', 'TEXTURE') and any(abs(v) > 1e-9 for v in node.inputs["Location"].default_value):
                return False
            node, out = _from(node.inputs["Vector"])
            continue
        if node.bl_idname != 'ShaderNodeTexCoord' or out.name not in ("Generated", "Object"):
            return False
        # Object with an object: Cycles moves the direction by the inverse matrix as a point,
        # translation included (svm/tex_coord.h): not a 3x3 matrix, the graph says it.
        return not (out.name == "Object" and node.object is not None
                    and any(abs(node.object.matrix_world[i][3]) > 1e-9 for i in range(3)))
    return True


def _graph(world, out, warnings):
    """The World's tree as {"type": "graph", "nodes", "surface"} (docs/scene-format.md)."""
    g = node_graph.NodeGraph(f"world {world.name}", warnings)

    def closure(socket, depth=0):
        node, _ = _from(socket)
        if node is None or depth > 64:
            return {"type": "background", "color": [0.0, 0.0, 0.0], "strength": 0.0}
        t = node.bl_idname
        if t == 'ShaderNodeAddShader':
            return {"type": "add", "a": closure(node.inputs[0], depth + 1), "b": closure(node.inputs[1], depth + 1)}
        if t == 'ShaderNodeMixShader':
            fac = g.value(node.inputs["Fac"], (), f"{node.name} Fac")
            return {"type": "mix", "factor": 0.5 if fac is None else fac,
                    "a": closure(node.inputs[1], depth + 1), "b": closure(node.inputs[2], depth + 1)}
        if t != 'ShaderNodeBackground':
            warnings.add("unsupported world shader (black environment)", f"world '{world.name}': node '{node.name}'")
            return {"type": "background", "color": [0.0, 0.0, 0.0], "strength": 0.0}
        color = g.value(node.inputs["Color"], (), f"{node.name} Color")
        strength = g.value(node.inputs["Strength"], (), f"{node.name} Strength")
        return {"type": "background", "color": [1.0, 1.0, 1.0] if color is None else color,
                "strength": 1.0 if strength is None else strength}

    env = {"type": "graph", "surface": closure(out.inputs["Surface"])}
    env["nodes"] = g.nodes
    settings = getattr(world, "cycles", None)
    if settings is not None and getattr(settings, "sampling_method", 'AUTOMATIC') == 'MANUAL':
        env["sampling_resolution"] = int(settings.sample_map_resolution)
    return env


def _is_camera_ray(socket):
    node, out = _from(socket)
    return node is not None and node.bl_idname == 'ShaderNodeLightPath' and out.name == "Is Camera Ray"


def _backgrounds(world, node, warnings):
    """A tree of Mix / Add Shaders over Background nodes as one background description: the
    single term itself, or {"type": "sum", "backgrounds": [...]} with each term's strength (a
    colour's colour) times the factors above it. None for black or unsupported."""
    terms = []
    _collect(world, node, 1.0, terms, warnings)
    terms = [t for t in terms if t is not None]
    if not terms:
        return None
    return terms[0] if len(terms) == 1 else {"type": "sum", "backgrounds": terms}


def _collect(world, node, weight, terms, warnings):
    if node is None or weight <= 0.0:
        return
    if node.bl_idname == 'ShaderNodeAddShader':
        for i in (0, 1):
            _collect(world, _from(node.inputs[i])[0], weight, terms, warnings)
        return
    if node.bl_idname == 'ShaderNodeMixShader':
        fac = node.inputs["Fac"]
        if fac.is_linked:
            src, out = _from(fac)
            warnings.add("unsupported world node (socket value used)",
                         f"world '{world.name}': node '{src.name if src else '?'}' ({out.name if out else '?'}) "
                         f"into {node.name}: Fac (rendered as {_value(fac)})")
        f = min(max(fac.default_value, 0.0), 1.0)  # Cycles clamps a Mix Shader's factor
        _collect(world, _from(node.inputs[1])[0], weight * (1.0 - f), terms, warnings)
        _collect(world, _from(node.inputs[2])[0], weight * f, terms, warnings)
        return
    bg = _background(world, node, warnings)
    if bg is None:
        return
    bg["strength"] = bg.get("strength", 1.0) * weight
    terms.append(bg)


def _background(world, node, warnings):
    """One Background node as {"color", "strength"}, a map or a sky; None for black or unsupported."""
    if node is None:
        return None
    if node.bl_idname != 'ShaderNodeBackground':
        warnings.add("unsupported world shader (black environment)", f"world '{world.name}': node '{node.name}'")
        return None
    color, strength = node.inputs["Color"], node.inputs["Strength"]
    if strength.is_linked:
        src, _ = _from(strength)
        warnings.add("unsupported world node (socket value used)",
                     f"world '{world.name}': node '{src.name if src else '?'}' into {node.name}: Strength "
                     f"(rendered as {_value(strength)})")
    s = max(0.0, strength.default_value)
    src, out = _from(color)
    if src is not None and src.bl_idname == 'ShaderNodeTexEnvironment' and out.name == "Color":
        env = _environment_texture(world, src, warnings)
        env["strength"] = s
        return env
    if src is not None and src.bl_idname == 'ShaderNodeTexSky' and out.name == "Color":
        env = _sky_texture(world, src, warnings)
        env["strength"] = s
        return env
    if src is not None:
        warnings.add("unsupported world node (socket value used)",
                     f"world '{world.name}': node '{src.name}' into {node.name}: Color (rendered as {_value(color)})")
    c = color.default_value
    return {"color": [c[0], c[1], c[2]], "strength": s}


_SKY_TYPES = {'NISHITA': "nishita", 'PREETHAM': "preetham", 'HOSEK_WILKIE': "hosek_wilkie"}


def _sky_texture(world, node, warnings):
    """A Sky Texture's settings in the scene format's units (degrees, metres); the core
    precomputes it as Cycles 3.4 does (lights/sky.h)."""
    where = f"world '{world.name}': node '{node.name}'"
    sky = {"type": "sky", "sky_type": _SKY_TYPES.get(node.sky_type, "nishita")}
    # Blender 3.4 makes the Vector socket unavailable for Nishita with its sun disc (what feeds it
    # is ignored, as Cycles does); otherwise a Mapping turns the sky (the core normalises the
    # vector, as the sky reads its angles).
    if node.inputs["Vector"].enabled:
        m = _vector_transform(world, node.inputs["Vector"], warnings)
        if m is not None:
            sky["transform"] = m
    if node.sky_type == 'HOSEK_WILKIE':
        # The model's fitted tables are not available to the core: Preetham with the same sun
        # direction and turbidity (ground albedo unused), one warning naming the node.
        warnings.add("Hosek-Wilkie sky rendered as Preetham", f"{where} (ground albedo {node.ground_albedo:.3g} unused)")
        sky["sky_type"] = "preetham"
    if node.sky_type == 'NISHITA':
        sky.update({"sun_disc": bool(node.sun_disc), "sun_size": math.degrees(node.sun_size),
                    "sun_intensity": node.sun_intensity, "sun_elevation": math.degrees(node.sun_elevation),
                    "sun_rotation": math.degrees(node.sun_rotation), "altitude": node.altitude,
                    "air_density": node.air_density, "dust_density": node.dust_density,
                    "ozone_density": node.ozone_density})
    else:
        sky.update({"sun_direction": list(node.sun_direction), "turbidity": node.turbidity})
    return sky


def _environment_texture(world, node, warnings):
    where = f"world '{world.name}': node '{node.name}'"
    path, why = texture.image_file(node.image)
    if path is None:
        if node.image is not None and why.startswith("file not found"):
            path = why.split(": ", 1)[1]  # the core renders it magenta, with one warning
        else:
            warnings.add("missing image texture (magenta)", f"{where}: {why}")
            return {"color": list(texture.MAGENTA)}
    env = {"type": "map", "image": path,
           "interpolation": _INTERPOLATION.get(node.interpolation, "linear"),
           "projection": _PROJECTION.get(node.projection, "equirectangular")}
    cs = node.image.colorspace_settings.name if node.image is not None else ""
    if cs:
        env["colorspace"] = cs
    m = _vector_transform(world, node.inputs["Vector"], warnings)
    if m is not None:
        env["transform"] = m
    settings = getattr(world, "cycles", None)
    method = getattr(settings, "sampling_method", 'AUTOMATIC') if settings else 'AUTOMATIC'
    if method == 'MANUAL':
        env["sampling_resolution"] = int(settings.sample_map_resolution)
    elif method == 'NONE':
        warnings.add("world sampling None read as Auto (the map is always importance-sampled)", f"world '{world.name}'")
    return env


def _matmul(a, b):
    return [[sum(a[i][k] * b[k][j] for k in range(3)) for j in range(3)] for i in range(3)]


def _euler_xyz(r):
    """Blender's XYZ Euler rotation matrix Rz Ry Rx (mathutils.Euler(r, 'XYZ').to_matrix())."""
    cx, sx, cy, sy, cz, sz = math.cos(r[0]), math.sin(r[0]), math.cos(r[1]), math.sin(r[1]), math.cos(r[2]), math.sin(r[2])
    rx = [[1, 0, 0], [0, cx, -sx], [0, sx, cx]]
    ry = [[cy, 0, sy], [0, 1, 0], [-sy, 0, cy]]
    rz = [[cz, -sz, 0], [sz, cz, 0], [0, 0, 1]]
    return _matmul(rz, _matmul(ry, rx))


def _inverse(m):
    a = m
    det = (a[0][0] * (a[1][1] * a[2][2] - a[1][2] * a[2][1]) - a[0][1] * (a[1][0] * a[2][2] - a[1][2] * a[2][0]) +
           a[0][2] * (a[1][0] * a[2][1] - a[1][1] * a[2][0]))
    if det == 0:
        return None
    return [[(a[(c + 1) % 3][(r + 1) % 3] * a[(c + 2) % 3][(r + 2) % 3] -
              a[(c + 1) % 3][(r + 2) % 3] * a[(c + 2) % 3][(r + 1) % 3]) / det for c in range(3)] for r in range(3)]


def _mapping(node, warnings, where):
    """The linear part of a Mapping node (Cycles' svm_mapping / mapping.h): Point and Vector
    R S v (+ location for Point, which a direction ignores: warned), Texture (R S)^-1, Normal
    R S^-1 (then normalised, as the texture normalises anyway)."""
    for name in ("Location", "Rotation", "Scale"):
        if node.inputs[name].is_linked:
            warnings.add("unsupported world node (socket value used)", f"{where}: {node.name}: {name} linked")
    rot = list(node.inputs["Rotation"].default_value)
    scale = list(node.inputs["Scale"].default_value)
    loc = list(node.inputs["Location"].default_value)
    r = _euler_xyz(rot)
    s = [[scale[0], 0, 0], [0, scale[1], 0], [0, 0, scale[2]]]
    kind = node.vector_type
    if kind in ('POINT', 'TEXTURE') and any(abs(v) > 1e-9 for v in loc):
        warnings.add("world Mapping location ignored (a direction has no position)", f"{where}: {node.name}")
    if kind == 'TEXTURE':
        return _inverse(_matmul(r, s))
    if kind == 'NORMAL':
        if 0.0 in scale:
            return None
        return _matmul(r, [[1 / scale[0], 0, 0], [0, 1 / scale[1], 0], [0, 0, 1 / scale[2]]])
    return _matmul(r, s)


def _vector_transform(world, socket, warnings):
    """World direction -> the texture's vector through Mapping and Texture Coordinate nodes, as
    a 3x3 matrix (None: identity)."""
    where = f"world '{world.name}'"
    m = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]
    node, out = _from(socket)
    while node is not None:
        if node.bl_idname == 'ShaderNodeMapping':
            mm = _mapping(node, warnings, where)
            if mm is None:
                warnings.add("unsupported world node (identity used)", f"{where}: {node.name}: zero scale")
            else:
                m = _matmul(m, mm)  # the Mapping nearer the texture applies last: M = M_near M_far
            node, out = _from(node.inputs["Vector"])
            continue
        if node.bl_idname == 'ShaderNodeTexCoord' and out.name in ("Generated", "Object"):
            if out.name == "Object" and node.object is not None:
                inv = _inverse([list(node.object.matrix_world[i])[:3] for i in range(3)])
                if inv is not None:
                    m = _matmul(m, inv)
            break
        warnings.add("unsupported world node (direction used)", f"{where}: node '{node.name}' ({out.name})")
        break
    if m == [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]:
        return None
    return m


def _value(socket):
    """A socket's own value as a report shows it: 0.8, or (0.05, 0.1, 0.2) for a colour."""
    v = socket.default_value
    if isinstance(v, float):
        return f"{v:.3g}"
    return "(" + ", ".join(f"{x:.3g}" for x in tuple(v)[:3]) + ")"
