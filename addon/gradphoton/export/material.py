"""Materials: Blender shader nodes -> the core's material set (docs/scene-format.md).

Mapped: Principled BSDF (base colour, metallic, roughness, specular, transmission, IOR,
emission), Diffuse (its Roughness: Oren-Nayar), Glossy (conductor), Glass, Refraction,
Transparent (any colour), Translucent, Velvet and Emission BSDFs, Mix Shader and Add Shader of
any of these (nested too), a material without nodes (its viewport diffuse colour). Blender
roughness r becomes the GGX alpha r^2; the Beckmann, Ashikhmin-Shirley and Multiscatter GGX
distributions render as GGX (a counted warning).

Principled BSDF, as layers of the core's materials:
  - the non-metal part is the core's `principled`: Cycles 3.4's two closures added, Burley's
    diffuse with its retro-reflection (roughness r) and a GGX specular lobe (alpha r^2) with the
    dielectric Fresnel of IOR (1 + sqrt F0) / (1 - sqrt F0), F0 = 0.08 Specular, as Cycles;
  - Metallic m mixes it with a conductor of the base colour: mix(principled, metal, m), as
    Cycles' weights (diffuse 1 - m, its one specular closure linear in m);
  - Transmission t mixes that with glass: mix(..., glass, (1 - m) t).
  Specular Tint is ignored (a counted warning); the metal's Fresnel is Cycles': the base colour
  blended toward white by the dielectric Fresnel of the Specular IOR (the core's conductor with
  "fresnel": "principled").

Textures (export/texture.py): an Image Texture may drive Base Color / Color, Roughness,
Metallic (the mix factor of the metal layer), Alpha (coverage: a stochastic cut-out), a Mix
Shader's Fac; Normal inputs take a Normal Map or Bump node. Normal maps, bump and alpha belong
to the whole material (lifted out of Mix/Add parts; the first found wins). A Mix Shader with a
Transparent BSDF on one side is the other side with that coverage (alpha).

Approximations, each a counted warning (Warnings) rather than silence:
  - a linked input fed by anything but the image chains above uses the socket's own value;
  - sheen, clearcoat and subsurface of a Principled BSDF are dropped;
  - any other shader node (Toon, Hair, Holdout, ...) renders as 0.8 grey diffuse.
Emission is two-sided, as in Cycles; inside a Mix or Add it is weighted like the BSDFs.
Dispersion comes from the material's gradphoton panel.
"""

from .texture import TextureReader
from .volume import export_volume, volume_socket

DEFAULT = "__gradphoton_default"
# Keys that belong to the whole material, not to one layer of it (lifted out of mix parts).
SURFACE_KEYS = ("normal_map", "bump", "alpha")


def _rgb(socket):
    v = socket.default_value
    return [float(v[0]), float(v[1]), float(v[2])]


class MaterialExporter:
    def __init__(self, table, warnings, media=None):
        self.table = table  # name -> scene-format material dict
        self.media = media if media is not None else {}  # name -> scene-format medium (Volume outputs)
        self.w = warnings
        self._used = {}     # Blender materials exported, by name
        self.tex = TextureReader(warnings)
        self._textured = set()  # exported materials that read textures (their meshes need UVs)

    def used_materials(self):
        return list(self._used.values())

    def needs_uvs(self, mat):
        """True when Blender material `mat` reads a texture (its meshes must export UVs)."""
        return mat is not None and mat.name in self._textured

    def name_for(self, mat, flags=None):
        """The core's material name for a Blender material (None: the default grey), with an
        object's visibility flags (export/visibility.py) as a variant of it."""
        if mat is None:
            if DEFAULT not in self.table:
                self.table[DEFAULT] = {"type": "diffuse", "color": 0.8}
            name = DEFAULT
        else:
            name = mat.name
            self._used[name] = mat
            if name not in self.table:
                self.tex.used = False
                self.table[name] = self.convert(mat)
                if self.tex.used:
                    self._textured.add(name)
        if not flags:
            return name
        variant = name + " [" + ", ".join(f"{k}={v}" for k, v in sorted(flags.items())) + "]"
        if variant not in self.table:
            self.table[variant] = dict(self.table[name], **flags)
        return variant

    # ---- helpers ----

    def _value(self, node, name, mat):
        s = node.inputs[name]
        if s.is_linked:
            self.w.add("linked input uses its own value (node unsupported)",
                       f"'{mat.name}': {node.name}.{name}")
        return s

    def _input(self, node, name, mat, scalar=False, square=False):
        """An input's value: a texture dict when an image drives it, else its constant (a float
        when scalar, squared when asked: Blender roughness r -> GGX alpha r^2; else [r, g, b])."""
        s = node.inputs[name]
        if s.is_linked:
            ref = self.tex.value(s, mat, scalar, square)
            if ref is not None:
                return ref
            self.w.add("linked input uses its own value (node unsupported)", f"'{mat.name}': {node.name}.{name}")
        v = s.default_value
        if scalar:
            return float(v) * float(v) if square else float(v)
        return [float(v[0]), float(v[1]), float(v[2])]

    def _with_normal(self, d, node, mat):
        if "Normal" in node.inputs:
            d.update(self.tex.normal(node.inputs["Normal"], mat))
        return d

    def _surface_node(self, mat):
        tree = mat.node_tree
        outputs = [n for n in tree.nodes if n.bl_idname == 'ShaderNodeOutputMaterial']
        out = next((n for n in outputs if n.is_active_output and n.target in {'ALL', 'CYCLES'}), None)
        out = out or next((n for n in outputs if n.target in {'ALL', 'CYCLES'}), None)
        if out is None or not out.inputs["Surface"].is_linked:
            return None
        link = out.inputs["Surface"].links[0]
        node = link.from_node
        while node.bl_idname == 'NodeReroute' and node.inputs[0].is_linked:
            node = node.inputs[0].links[0].from_node
        return node

    # ---- conversion ----

    def convert(self, mat):
        if not mat.use_nodes or mat.node_tree is None:
            c = mat.diffuse_color
            return self._dispersion({"type": "diffuse", "color": [c[0], c[1], c[2]]}, mat)
        # The Volume output: the medium inside the material's closed meshes (export/volume.py).
        medium = None
        node = self._surface_node(mat)
        socket = volume_socket(mat.node_tree, 'ShaderNodeOutputMaterial')
        if socket is not None:
            medium = export_volume(socket, f"material '{mat.name}'", self.w, keep_empty=node is None)
        if node is None:
            if medium is not None:  # a volume without a surface: a pass-through boundary (Cycles)
                self.media[mat.name] = medium
                return {"type": "volume", "interior": mat.name}
            return {"type": "diffuse", "color": 0.0}  # Cycles renders an unconnected output black
        d = self._one_sided(self._dispersion(self._node(node, mat, 0), mat), mat)
        if medium is not None:
            self.media[mat.name] = medium
            d["interior"] = mat.name
        return d

    @staticmethod
    def _linked_node(socket):
        node = socket.links[0].from_node if socket.is_linked else None
        while node is not None and node.bl_idname == 'NodeReroute':
            node = node.inputs[0].links[0].from_node if node.inputs[0].is_linked else None
        return node

    def _part(self, d, mat, node, label):
        """Registers `d`, a component of material `mat`, in the table; returns its name."""
        name = f"{mat.name}/{node.name}/{label}"
        self.table[name] = d
        return name

    def _node(self, node, mat, depth):
        """The scene-format material of one shader node (recursing into Mix/Add Shader)."""
        kind = node.bl_idname
        if depth > 16:
            self.w.add("shader nodes nested too deep rendered as grey diffuse", f"'{mat.name}'")
            return {"type": "diffuse", "color": 0.8}
        if kind == 'ShaderNodeBsdfPrincipled':
            return self._principled(node, mat)
        if kind == 'ShaderNodeBsdfDiffuse':  # Roughness: Cycles' Oren-Nayar sigma, as it is (not squared)
            return self._with_normal({"type": "diffuse", "color": self._input(node, "Color", mat),
                                      "roughness": self._input(node, "Roughness", mat, scalar=True)}, node, mat)
        if kind == 'ShaderNodeBsdfTransparent':  # straight through, tinted (a delta closure)
            return {"type": "transparent", "color": self._input(node, "Color", mat)}
        if kind == 'ShaderNodeBsdfTranslucent':
            return self._with_normal({"type": "translucent", "color": self._input(node, "Color", mat)}, node, mat)
        if kind == 'ShaderNodeBsdfVelvet':
            return self._with_normal({"type": "velvet", "color": self._input(node, "Color", mat),
                                      "sigma": min(1.0, max(0.0, self._value(node, "Sigma", mat).default_value))},
                                     node, mat)
        if kind in ('ShaderNodeBsdfGlossy', 'ShaderNodeBsdfAnisotropic', 'ShaderNodeBsdfGlass',
                    'ShaderNodeBsdfRefraction') and node.distribution not in ('GGX', 'SHARP'):
            self.w.add("glossy distribution rendered as GGX", f"'{mat.name}': {node.name} ({node.distribution})")
        if kind in ('ShaderNodeBsdfGlossy', 'ShaderNodeBsdfAnisotropic'):
            return self._with_normal({"type": "conductor", "color": self._input(node, "Color", mat),
                                      "roughness": self._input(node, "Roughness", mat, scalar=True, square=True),
                                      "fresnel": False}, node, mat)  # Cycles' Glossy BSDF: the colour at every angle
        if kind in ('ShaderNodeBsdfGlass', 'ShaderNodeBsdfRefraction'):
            # Refraction BSDF: glass's refraction lobe alone, without Fresnel (the core's "refraction").
            t = "dielectric" if kind == 'ShaderNodeBsdfGlass' else "refraction"
            return self._with_normal({"type": t, "color": self._input(node, "Color", mat),
                                      "roughness": self._input(node, "Roughness", mat, scalar=True, square=True),
                                      "ior": max(1e-3, self._value(node, "IOR", mat).default_value)}, node, mat)
        if kind == 'ShaderNodeEmission':
            return {"type": "emission", "emission": _rgb(self._value(node, "Color", mat)),
                    "strength": max(0.0, self._value(node, "Strength", mat).default_value), "two_sided": True}
        if kind in ('ShaderNodeMixShader', 'ShaderNodeAddShader'):
            return self._mix(node, mat, depth)
        self.w.add("unsupported shader node rendered as grey diffuse", f"'{mat.name}': {node.name}")
        return {"type": "diffuse", "color": 0.8}

    def _mix(self, node, mat, depth):
        add = node.bl_idname == 'ShaderNodeAddShader'
        if add:
            t, sockets = 0.5, (node.inputs[0], node.inputs[1])
        else:
            t = self._input(node, "Fac", mat, scalar=True)
            if not isinstance(t, dict):
                t = min(1.0, max(0.0, t))
            sockets = (node.inputs[1], node.inputs[2])
            cut_out = self._transparent_mix(sockets, t, mat, depth)
            if cut_out is not None:
                return cut_out
        if isinstance(t, dict) and any(self._linked_node(s) is not None and
                                       self._linked_node(s).bl_idname == 'ShaderNodeEmission' for s in sockets):
            self.w.add("emission in a texture-weighted Mix Shader weighted by one half", f"'{mat.name}': {node.name}")
        parts = []
        for s in sockets:
            src = self._linked_node(s)
            # An unconnected shader socket is no closure: black, as in Cycles.
            parts.append(self._node(src, mat, depth + 1) if src is not None else {"type": "emission", "strength": 0.0})
        # Emission inside a mix, weighted like the BSDFs, is carried by the mix itself (the
        # core takes a mix's emission from the mix, not from its parts).
        emission = [0.0, 0.0, 0.0]
        tw = 0.5 if isinstance(t, dict) else t
        lifted = {}
        for d in parts:
            for key in SURFACE_KEYS:
                if key in d:
                    lifted.setdefault(key, d.pop(key))
        for d, w in zip(parts, (1.0, 1.0) if add else (1.0 - tw, tw)):
            if d.get("strength", 0) > 0 and "emission" in d:
                emission = [acc + w * d["strength"] * c for acc, c in zip(emission, d["emission"])]
            for key in ("emission", "strength", "two_sided"):
                d.pop(key, None)
        out = {"type": "add" if add else "mix",
               "a": self._part(parts[0], mat, node, "a"), "b": self._part(parts[1], mat, node, "b")}
        if not add:
            out["factor"] = t
        if any(c > 0 for c in emission):
            out.update({"emission": emission, "strength": 1.0, "two_sided": True})
        out.update(lifted)
        return out

    def _transparent_mix(self, sockets, t, mat, depth):
        """Mix Shader of a Transparent BSDF (white) and one other shader: that shader with
        coverage alpha = Fac (transparent first) or 1 - Fac (transparent second); None otherwise."""
        nodes = [self._linked_node(s) for s in sockets]
        kinds = [n.bl_idname if n is not None else None for n in nodes]
        if kinds.count('ShaderNodeBsdfTransparent') != 1:
            return None
        k = kinds.index('ShaderNodeBsdfTransparent')
        other = nodes[1 - k]
        if any(c < 0.999 for c in nodes[k].inputs["Color"].default_value[:3]) or nodes[k].inputs["Color"].is_linked:
            return None  # a tinted transparency is no cut-out
        if k == 1 and isinstance(t, dict):
            self.w.add("texture-driven coverage with Transparent second read as opaque", f"'{mat.name}'")
            return None
        alpha = t if k == 0 else 1.0 - t
        d = self._node(other, mat, depth + 1) if other is not None else {"type": "emission", "strength": 0.0}
        if isinstance(alpha, dict) or alpha < 1.0:
            d["alpha"] = alpha
        return d

    @staticmethod
    def _one_sided(d, mat):
        gp = getattr(mat, "gradphoton", None)
        if gp is not None and gp.emission_one_sided and "strength" in d:
            d["two_sided"] = False
        return d

    def _principled(self, node, mat):
        base = self._input(node, "Base Color", mat)
        metallic = self._input(node, "Metallic", mat, scalar=True)
        alpha = self._input(node, "Roughness", mat, scalar=True, square=True)  # GGX alpha = r^2
        trans = min(1.0, max(0.0, self._value(node, "Transmission", mat).default_value))
        spec = max(0.0, self._value(node, "Specular", mat).default_value)
        # Cycles: F0 = 0.08 Specular for the specular lobe: IOR (1 + sqrt F0) / (1 - sqrt F0)
        # (Specular 0: IOR 1, no specular reflection, the Burley diffuse alone).
        sf0 = min(0.99, (0.08 * spec) ** 0.5)
        d = {"type": "principled", "color": base, "roughness": alpha, "ior": (1 + sf0) / (1 - sf0)}
        tint = node.inputs.get("Specular Tint")
        if tint is not None and (tint.is_linked or tint.default_value > 0):
            self.w.add("Principled BSDF Specular Tint ignored", f"'{mat.name}'")
        # Cycles' one specular closure of the metal: cspec0 = base colour, interpolated toward white
        # by the dielectric Fresnel of the same Specular-derived IOR (bsdf_util.h).
        metal = {"type": "conductor", "color": base, "roughness": alpha, "fresnel": "principled", "ior": d["ior"]}
        if isinstance(metallic, dict):  # a metallic map: the metal layer's weight per point
            d = {"type": "mix", "a": self._part(d, mat, node, "plastic"), "b": self._part(metal, mat, node, "metal"),
                 "factor": metallic}
            if trans > 0:
                self.w.add("Transmission with a Metallic texture weighted as if metallic were 0", f"'{mat.name}'")
            metallic = 0.0
        else:
            metallic = min(1.0, max(0.0, metallic))
            if metallic >= 1.0:
                d = metal
            elif metallic > 0:
                d = {"type": "mix", "a": self._part(d, mat, node, "plastic"),
                     "b": self._part(metal, mat, node, "metal"), "factor": metallic}
        t_glass = (1.0 - metallic) * trans
        glass = {"type": "dielectric", "color": base, "roughness": alpha,
                 "ior": max(1e-3, self._value(node, "IOR", mat).default_value)}
        if t_glass >= 1.0:
            d = glass
        elif t_glass > 0:
            d = {"type": "mix", "a": self._part(d, mat, node, "opaque"), "b": self._part(glass, mat, node, "glass"),
                 "factor": t_glass}
        for name in ("Subsurface", "Sheen", "Clearcoat"):
            s = node.inputs.get(name)
            if s is not None and (s.is_linked or s.default_value > 0):
                self.w.add("Principled BSDF layer dropped", f"'{mat.name}': {name}")
        emission = _rgb(self._value(node, "Emission", mat))
        strength = self._value(node, "Emission Strength", mat).default_value
        if strength > 0 and any(c > 0 for c in emission):
            d = dict(d, emission=emission, strength=strength, two_sided=True)
        coverage = self._input(node, "Alpha", mat, scalar=True)
        if isinstance(coverage, dict) or coverage < 1.0:
            d["alpha"] = coverage if isinstance(coverage, dict) else max(0.0, coverage)
        return self._with_normal(d, node, mat)

    def _dispersion(self, d, mat):
        gp = getattr(mat, "gradphoton", None)
        if gp is None or gp.dispersion == 'NONE':
            return d
        if d["type"] != "dielectric":
            self.w.add("dispersion needs a glass material (ignored)", f"'{mat.name}'")
        elif gp.dispersion == 'ABBE':
            d["abbe"] = gp.abbe
        else:
            d["cauchy_b"] = gp.cauchy_b
        return d
