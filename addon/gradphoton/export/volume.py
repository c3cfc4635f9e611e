"""Volumes: a material's or the World's Volume output -> a homogeneous medium of the core
(docs/scene-format.md, "Participating media"), as Cycles 3.4's SVM reads the volume closures
(kernel/svm/closure.h, svm_node_closure_volume and svm_node_principled_volume):

  - Volume Absorption: sigma_a = (1 - Color) x Density (Color is what is let through);
  - Volume Scatter: sigma_s = Color x Density, Henyey-Greenstein of Anisotropy;
  - Principled Volume: sigma_s = Color x Density; sigma_a = max(1 - Color, 0) x
    max(1 - sqrt(Absorption Color), 0) x Density; emission = Emission Strength x Emission
    Color (radiance per metre; not weighted by a Mix Shader's factor, as in Cycles);
  - Add Shader sums, Mix Shader weighs each side by (1 - Fac) and Fac (Cycles multiplies the
    density by the mix weight); Emission (a volume's emission closure) adds Strength x Color.
Overlapping lobes of different anisotropy become one whose g is their scattering-weighted
mean (a counted warning). Linked inputs are warnings, the socket's own value used. Negative
densities are 0, as in Cycles.

On a Volume object (export/volume_object.py) Principled Volume's Density / Color / Temperature
Attributes name grids of its OpenVDB file: the medium gets a "grid" (docs/scene-format.md) with
the node's own values, and its blackbody emission is rendered (per point, from the temperature
grid or the Temperature socket). On a mesh the attributes find nothing (as in Cycles: a mesh's
volume is homogeneous), and blackbody emission is a warning.
"""
import math

from .links import linked_from as _from


def _rgb(socket):
    v = socket.default_value
    return [float(v[0]), float(v[1]), float(v[2])]


class _Medium:
    def __init__(self):
        self.sigma_a = [0.0, 0.0, 0.0]
        self.sigma_s = [0.0, 0.0, 0.0]
        self.emission = [0.0, 0.0, 0.0]
        self.g_weighted = 0.0  # sum of g x mean sigma_s over the lobes
        self.lobes = []        # g of each scattering lobe
        self.principled = []   # each Principled Volume's values (what a grid medium needs)

    def add_scatter(self, sigma_s, g):
        for k in range(3):
            self.sigma_s[k] += sigma_s[k]
        w = sum(sigma_s) / 3.0
        if w > 0:
            self.g_weighted += g * w
            self.lobes.append(g)

    def as_dict(self):
        d = {"sigma_a": self.sigma_a, "sigma_s": self.sigma_s}
        s = sum(self.sigma_s) / 3.0
        g = self.g_weighted / s if s > 0 else 0.0
        if g != 0.0:
            d["g"] = max(-1.0, min(1.0, g))
        if any(e > 0 for e in self.emission):
            d["emission"] = self.emission
        return d


def volume_socket(tree, output_type):
    """The Volume input of the active output node of `tree` (material or world), if linked."""
    if tree is None:
        return None
    outs = [n for n in tree.nodes if n.bl_idname == output_type]
    out = next((n for n in outs if n.is_active_output and getattr(n, "target", 'ALL') in {'ALL', 'CYCLES'}), None)
    out = out or next((n for n in outs if getattr(n, "target", 'ALL') in {'ALL', 'CYCLES'}), None)
    if out is None or out.inputs.get("Volume") is None or not out.inputs["Volume"].is_linked:
        return None
    return out.inputs["Volume"]


def export_volume(socket, owner, warnings, keep_empty=False, grids=None):
    """The scene-format medium of what feeds `socket` (a Volume input), or None when it adds
    nothing (unless keep_empty: a volume-only material's boundary stays one, as in Cycles).
    `owner` names the material or world in warnings ("material 'Smoke'"). `grids`: on a Volume
    object, {"file": path, "names": the file's grid names} (the Principled Volume's attributes
    look them up); on a smoke domain {"file": path, "map": attribute -> scene-format keys}
    (export/fluid.py); None elsewhere."""
    node, _ = _from(socket)
    m = _Medium()
    if node is not None:
        _add(node, 1.0, m, owner, warnings, 0)
    elif grids is not None:
        _default_volume(m)
    if len(set(m.lobes)) > 1:
        warnings.add("volume lobes of different anisotropy merged into one", owner)
    d = m.as_dict()
    grid = _grid_of(m, grids, owner, warnings)
    if grid is not None:
        d["grid"] = grid
        return d
    for p in m.principled:
        if p["blackbody_intensity"] > 0:
            warnings.add("volume blackbody emission not rendered", f"{owner}: {p['node']}")
    if not any(d["sigma_a"]) and not any(d["sigma_s"]) and "emission" not in d and not keep_empty:
        return None
    return d


def _value(node, name, owner, warnings):
    s = node.inputs[name]
    if s.is_linked:
        warnings.add("linked volume input uses its own value", f"{owner}: {node.name}.{name}")
    return s.default_value


def _color(node, name, owner, warnings):
    s = node.inputs[name]
    if s.is_linked:
        warnings.add("linked volume input uses its own value", f"{owner}: {node.name}.{name}")
    return _rgb(s)


def _add(node, weight, m, owner, warnings, depth):
    kind = node.bl_idname
    if depth > 16 or weight <= 0:
        return
    if kind == 'ShaderNodeAddShader':
        for s in node.inputs[:2]:
            child, _ = _from(s)
            if child is not None:
                _add(child, weight, m, owner, warnings, depth + 1)
        return
    if kind == 'ShaderNodeMixShader':
        fac = min(1.0, max(0.0, float(_value(node, "Fac", owner, warnings))))
        for s, w in ((node.inputs[1], 1.0 - fac), (node.inputs[2], fac)):
            child, _ = _from(s)
            if child is not None:
                _add(child, weight * w, m, owner, warnings, depth + 1)
        return
    if kind == 'ShaderNodeVolumeAbsorption':
        c = _color(node, "Color", owner, warnings)
        density = weight * max(0.0, float(_value(node, "Density", owner, warnings)))
        for k in range(3):
            m.sigma_a[k] += max(0.0, 1.0 - c[k]) * density
        return
    if kind == 'ShaderNodeVolumeScatter':
        c = _color(node, "Color", owner, warnings)
        density = weight * max(0.0, float(_value(node, "Density", owner, warnings)))
        g = float(_value(node, "Anisotropy", owner, warnings))
        m.add_scatter([max(0.0, c[k]) * density for k in range(3)], g)
        return
    if kind == 'ShaderNodeVolumePrincipled':
        _principled(node, weight, m, owner, warnings)
        return
    if kind == 'ShaderNodeEmission':
        c = _color(node, "Color", owner, warnings)
        strength = float(_value(node, "Strength", owner, warnings))
        for k in range(3):
            m.emission[k] += max(0.0, weight * strength * c[k])
        return
    warnings.add("unsupported volume shader node (left out)", f"{owner}: {node.name}")


def _principled(node, weight, m, owner, warnings):
    # (Its Density / Color / Temperature Attributes find nothing on a mesh in Cycles: a mesh's
    # volume is homogeneous; Volume objects' grids are the next landing.)
    density = weight * max(0.0, float(_value(node, "Density", owner, warnings)))
    c = _color(node, "Color", owner, warnings)
    absorption = _color(node, "Absorption Color", owner, warnings)
    g = float(_value(node, "Anisotropy", owner, warnings))
    if density > 0:
        m.add_scatter([max(0.0, c[k]) * density for k in range(3)], g)
        for k in range(3):
            a = max(0.0, 1.0 - max(0.0, c[k])) * max(0.0, 1.0 - math.sqrt(max(0.0, absorption[k])))
            m.sigma_a[k] += a * density
    # Cycles multiplies the density by the mix weight but not the emission (emission_setup of
    # Emission Strength x Emission Color as they are), so neither does this.
    strength = float(_value(node, "Emission Strength", owner, warnings))
    if strength > 0:
        e = _color(node, "Emission Color", owner, warnings)
        for k in range(3):
            m.emission[k] += max(0.0, strength * e[k])
    m.principled.append({
        "node": node.name, "density": density, "color": c, "absorption_color": absorption,
        "blackbody_intensity": min(1.0, max(0.0, float(_value(node, "Blackbody Intensity", owner, warnings)))),
        "blackbody_tint": _color(node, "Blackbody Tint", owner, warnings),
        "temperature": max(0.0, float(_value(node, "Temperature", owner, warnings))),
        "attributes": {key: node.inputs[socket].default_value for key, socket in _ATTRIBUTES}})


# Principled Volume's attribute sockets -> the scene format's grid keys.
_ATTRIBUTES = (("density_grid", "Density Attribute"), ("color_grid", "Color Attribute"),
               ("temperature_grid", "Temperature Attribute"))


def _default_volume(m):
    """Cycles' default volume shader (a Volume object without a material): Principled Volume
    with its defaults, reading the "density" grid."""
    c = [0.5, 0.5, 0.5]
    m.add_scatter([x for x in c], 0.0)
    for k in range(3):
        m.sigma_a[k] += 0.5
    m.principled.append({
        "node": "default volume", "density": 1.0, "color": c, "absorption_color": [0.0, 0.0, 0.0],
        "blackbody_intensity": 0.0, "blackbody_tint": [1.0, 1.0, 1.0], "temperature": 1000.0,
        "attributes": {"density_grid": "density", "color_grid": "", "temperature_grid": "temperature"}})


def _grid_of(m, grids, owner, warnings):
    """The scene format's "grid" of a Volume object's medium: the grids its Principled Volume's
    attributes name that the file has (None: none, the medium is homogeneous as in Cycles)."""
    if grids is None or not m.principled:
        return None
    if len(m.principled) > 1:
        warnings.add("several Principled Volumes on a Volume object: the first one's attributes used", owner)
    p = m.principled[0]
    g = {"file": grids["file"]}
    blackbody = p["blackbody_intensity"]
    for key, name in p["attributes"].items():
        if not name:
            continue
        if "map" not in grids:  # a Volume object: its attributes are the file's grids by name
            if name in grids["names"]:
                g[key] = name
            continue
        # A smoke domain: Cycles' standard attributes (export/fluid.py _attribute_map).
        entry = grids["map"].get(name)
        if entry is None:
            continue
        if "smoke_color_grids" in entry:
            if key == "color_grid":
                g["smoke_color_grids"] = entry["smoke_color_grids"]
        elif entry.get("zero"):
            if key == "temperature_grid":
                blackbody = 0.0  # T = 0: Cycles' intensity sigma 1e-6 / pi x mix(1, 0, b) is under its cutoff
        else:
            g[key] = entry["grid"]
            if key == "temperature_grid" and "flame_temperature" in entry:
                g["flame_temperature"] = entry["flame_temperature"]
    if len(g) == 1:
        return None  # (a blackbody without a grid to carry it: warned by the caller)
    g.update({"density": p["density"], "color": p["color"], "absorption_color": p["absorption_color"],
              "blackbody_intensity": blackbody, "blackbody_tint": p["blackbody_tint"],
              "temperature": p["temperature"]})
    if "transform" in grids:
        g["transform"] = grids["transform"]
    return g
