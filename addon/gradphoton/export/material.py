"""Materials: Blender shader nodes -> the core's material set (docs/scene-format.md).

Mapped: Principled BSDF (base colour, metallic, roughness, specular, transmission, IOR,
emission), Diffuse, Glossy (conductor), Glass and Emission BSDFs, Mix Shader and Add Shader of
any of these (nested too), a material without nodes (its viewport diffuse colour). Blender
roughness r becomes the GGX alpha r^2.

Principled BSDF, as layers of the core's materials:
  - the non-metal part is a plastic: a GGX dielectric coat (IOR from Specular, F0 = 0.08
    Specular, as Cycles) over a Fresnel-weighted diffuse base of the base colour;
  - Metallic m mixes it with a conductor of the base colour: mix(plastic, metal, m);
  - Transmission t mixes that with glass: mix(..., glass, (1 - m) t).
  Cycles 3.4's Principled diffuse is not Fresnel-weighted (Disney diffuse, the specular added
  on top): gradphoton's plastic reflects at most all the light, so a Principled non-metal
  renders a little darker than in Cycles (docs/blender.md gives the measured difference).

Approximations, each a counted warning (Warnings) rather than silence:
  - a linked input (a texture or any node feeding a socket) uses the socket's own value;
  - sheen, clearcoat and subsurface of a Principled BSDF are dropped;
  - any other shader node (Toon, Hair, Holdout, ...) renders as 0.8 grey diffuse.
Emission is two-sided, as in Cycles; inside a Mix or Add it is weighted like the BSDFs.
Dispersion comes from the material's gradphoton panel.
"""

DEFAULT = "__gradphoton_default"


def _rgb(socket):
    v = socket.default_value
    return [float(v[0]), float(v[1]), float(v[2])]


class MaterialExporter:
    def __init__(self, table, warnings):
        self.table = table  # name -> scene-format material dict
        self.w = warnings
        self._used = {}     # Blender materials exported, by name

    def used_materials(self):
        return list(self._used.values())

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
                self.table[name] = self.convert(mat)
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
            self.w.add("linked input uses its own value (textures unsupported)",
                       f"'{mat.name}': {node.name}.{name}")
        return s

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
        node = self._surface_node(mat)
        if node is None:
            return {"type": "diffuse", "color": 0.0}  # Cycles renders an unconnected output black
        return self._one_sided(self._dispersion(self._node(node, mat, 0), mat), mat)

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
        if kind == 'ShaderNodeBsdfDiffuse':
            if self._value(node, "Roughness", mat).default_value > 0:
                self.w.add("Oren-Nayar roughness ignored (Lambertian)", f"'{mat.name}'")
            return {"type": "diffuse", "color": _rgb(self._value(node, "Color", mat))}
        if kind in ('ShaderNodeBsdfGlossy', 'ShaderNodeBsdfAnisotropic'):
            r = self._value(node, "Roughness", mat).default_value
            return {"type": "conductor", "color": _rgb(self._value(node, "Color", mat)), "roughness": r * r,
                    "fresnel": False}  # Cycles' Glossy BSDF: the colour at every angle
        if kind in ('ShaderNodeBsdfGlass', 'ShaderNodeBsdfRefraction'):
            r = self._value(node, "Roughness", mat).default_value
            return {"type": "dielectric", "color": _rgb(self._value(node, "Color", mat)), "roughness": r * r,
                    "ior": max(1e-3, self._value(node, "IOR", mat).default_value)}
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
            t = min(1.0, max(0.0, self._value(node, "Fac", mat).default_value))
            sockets = (node.inputs[1], node.inputs[2])
        parts = []
        for s in sockets:
            src = self._linked_node(s)
            # An unconnected shader socket is no closure: black, as in Cycles.
            parts.append(self._node(src, mat, depth + 1) if src is not None else {"type": "emission", "strength": 0.0})
        # Emission inside a mix, weighted like the BSDFs, is carried by the mix itself (the
        # core takes a mix's emission from the mix, not from its parts).
        emission = [0.0, 0.0, 0.0]
        for d, w in zip(parts, (1.0, 1.0) if add else (1.0 - t, t)):
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
        return out

    @staticmethod
    def _one_sided(d, mat):
        gp = getattr(mat, "gradphoton", None)
        if gp is not None and gp.emission_one_sided and "strength" in d:
            d["two_sided"] = False
        return d

    def _principled(self, node, mat):
        base = _rgb(self._value(node, "Base Color", mat))
        metallic = min(1.0, max(0.0, self._value(node, "Metallic", mat).default_value))
        rough = self._value(node, "Roughness", mat).default_value
        trans = min(1.0, max(0.0, self._value(node, "Transmission", mat).default_value))
        spec = max(0.0, self._value(node, "Specular", mat).default_value)
        alpha = rough * rough
        # Cycles: F0 = 0.08 Specular for the dielectric layer: IOR (1 + sqrt F0) / (1 - sqrt F0).
        sf0 = min(0.99, (0.08 * spec) ** 0.5)
        d = {"type": "plastic", "color": base, "roughness": alpha, "ior": (1 + sf0) / (1 - sf0)}
        if sf0 == 0:  # Specular 0: no coat, the plastic is its Lambertian base
            d = {"type": "diffuse", "color": base}
        metal = {"type": "conductor", "color": base, "roughness": alpha}
        if metallic >= 1.0:
            d = metal
        elif metallic > 0:
            d = {"type": "mix", "a": self._part(d, mat, node, "plastic"), "b": self._part(metal, mat, node, "metal"),
                 "factor": metallic}
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
        return d

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
