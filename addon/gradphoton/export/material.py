"""Materials: Blender shader nodes -> the core's closed material set (docs/scene-format.md).

Mapped: Principled BSDF (base colour, metallic, roughness, transmission, IOR, emission),
Diffuse, Glossy (conductor), Glass and Emission BSDFs, a material without nodes (its viewport
diffuse colour). Blender roughness r becomes the GGX alpha r^2. Approximations, each a counted
warning (Warnings) rather than silence:
  - a linked input (a texture or any node feeding a socket) uses the socket's own value;
  - a Principled BSDF is one lobe: transmission >= 0.5 -> glass, else metallic >= 0.5 ->
    metal, else diffuse (its dielectric specular layer, sheen, clearcoat, subsurface dropped);
  - any other shader node (Mix, Add, Toon, ...) renders as 0.8 grey diffuse.
Emission is two-sided, as in Cycles. Dispersion comes from the material's gradphoton panel.
"""

DEFAULT = "__gradphoton_default"


def _rgb(socket):
    v = socket.default_value
    return [float(v[0]), float(v[1]), float(v[2])]


class MaterialExporter:
    def __init__(self, table, warnings):
        self.table = table  # name -> scene-format material dict
        self.w = warnings

    def name_for(self, mat):
        if mat is None:
            if DEFAULT not in self.table:
                self.table[DEFAULT] = {"type": "diffuse", "color": 0.8}
            return DEFAULT
        if mat.name not in self.table:
            self.table[mat.name] = self.convert(mat)
        return mat.name

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
        kind = node.bl_idname
        if kind == 'ShaderNodeBsdfPrincipled':
            d = self._principled(node, mat)
        elif kind == 'ShaderNodeBsdfDiffuse':
            d = {"type": "diffuse", "color": _rgb(self._value(node, "Color", mat))}
            if self._value(node, "Roughness", mat).default_value > 0:
                self.w.add("Oren-Nayar roughness ignored (Lambertian)", f"'{mat.name}'")
        elif kind == 'ShaderNodeBsdfGlossy' or kind == 'ShaderNodeBsdfAnisotropic':
            r = self._value(node, "Roughness", mat).default_value
            d = {"type": "conductor", "color": _rgb(self._value(node, "Color", mat)), "roughness": r * r}
        elif kind in ('ShaderNodeBsdfGlass', 'ShaderNodeBsdfRefraction'):
            r = self._value(node, "Roughness", mat).default_value
            d = {"type": "dielectric", "color": _rgb(self._value(node, "Color", mat)), "roughness": r * r,
                 "ior": max(1e-3, self._value(node, "IOR", mat).default_value)}
        elif kind == 'ShaderNodeEmission':
            d = {"type": "emission", "emission": _rgb(self._value(node, "Color", mat)),
                 "strength": max(0.0, self._value(node, "Strength", mat).default_value), "two_sided": True}
        else:
            self.w.add("unsupported shader node rendered as grey diffuse", f"'{mat.name}': {node.name}")
            d = {"type": "diffuse", "color": 0.8}
        return self._one_sided(self._dispersion(d, mat), mat)

    @staticmethod
    def _one_sided(d, mat):
        gp = getattr(mat, "gradphoton", None)
        if gp is not None and gp.emission_one_sided and "strength" in d:
            d["two_sided"] = False
        return d

    def _principled(self, node, mat):
        base = _rgb(self._value(node, "Base Color", mat))
        metallic = self._value(node, "Metallic", mat).default_value
        rough = self._value(node, "Roughness", mat).default_value
        trans = self._value(node, "Transmission", mat).default_value
        if trans >= 0.5:
            d = {"type": "dielectric", "color": base, "roughness": rough * rough,
                 "ior": max(1e-3, self._value(node, "IOR", mat).default_value)}
        elif metallic >= 0.5:
            d = {"type": "conductor", "color": base, "roughness": rough * rough}
        else:
            d = {"type": "diffuse", "color": base}
        if 0 < trans < 1 or 0 < metallic < 1:
            self.w.add("Principled BSDF blend rounded to one lobe", f"'{mat.name}'")
        for name in ("Subsurface", "Sheen", "Clearcoat"):
            s = node.inputs.get(name)
            if s is not None and (s.is_linked or s.default_value > 0):
                self.w.add("Principled BSDF layer dropped", f"'{mat.name}': {name}")
        emission = _rgb(self._value(node, "Emission", mat))
        strength = self._value(node, "Emission Strength", mat).default_value
        if strength > 0 and any(c > 0 for c in emission):
            d.update({"emission": emission, "strength": strength, "two_sided": True})
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
