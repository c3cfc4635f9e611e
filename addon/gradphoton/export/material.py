"""Materials: Blender shader trees -> the core's closures with node-graph inputs
(docs/scene-format.md, "Materials" and "Node graphs").

The closure tree (what reaches the active Cycles Material Output's Surface) maps onto the core's
closure types; every non-closure input of a closure is a constant or a link into the
material's node table (export/nodes.py writes the table: groups flattened, reroutes and muted
nodes resolved, as Cycles reads the tree). Closures:

  - Diffuse BSDF (its Roughness: Cycles' Oren-Nayar sigma), Glossy / Anisotropic BSDF (the core's
    conductor without Fresnel, as Cycles' Glossy), Glass BSDF (dielectric; GGX, Beckmann and Sharp
    with "fresnel": "normal", Cycles 3.4's split into reflection and refraction closures weighted
    by the Fresnel at the shading normal), Refraction BSDF (its
    refraction lobe alone), Transparent (any colour), Translucent, Velvet, Emission (two-sided, as
    in Cycles), Mix Shader and Add Shader of any of these, nested; every Distribution each node has
    in Blender 3.4 (GGX, Beckmann, Ashikhmin-Shirley, Multiscatter GGX: the core's `distribution`);
  - Principled BSDF, as layers of the core's materials:
      the non-metal part is the core's `principled`: Cycles 3.4's two closures added, Burley's
      diffuse with its retro-reflection (roughness r) and a GGX specular lobe (alpha r^2) with the
      dielectric Fresnel of IOR (1 + sqrt F0) / (1 - sqrt F0), F0 = 0.08 Specular, as Cycles;
      Metallic m mixes it with a conductor of the base colour: mix(principled, metal, m), as
      Cycles' weights (diffuse 1 - m, its one specular closure linear in m);
      Transmission t mixes that with glass: mix(..., glass, (1 - m) t).
    The metal's Fresnel is Cycles': the base colour blended toward white by the dielectric
    Fresnel of the Specular IOR (the core's conductor with "fresnel": "principled").
    Specular Tint, Sheen and Sheen Tint are the non-metal part's (`specular_tint`, `sheen`,
    `sheen_tint`); Clearcoat is Cycles' clearcoat closure (the core's `clearcoat`: GTR1 of alpha
    Clearcoat Roughness^2, its own Clearcoat Normal) added to the rest: add(..., clearcoat).
    Anisotropic / Anisotropic Rotation / Tangent make the specular lobes (principled, metal)
    anisotropic: `anisotropy` = sqrt(1 - 0.9 a) - 1 in the Anisotropic BSDF's convention, which
    the Anisotropic BSDF node writes as it is (GGX and Beckmann; Ashikhmin-Shirley stays isotropic
    with a counted warning); an unlinked Tangent is Cycles' radial one about the object's Z axis.
    Its Distribution (GGX, Multiscatter GGX) is every lobe's. Subsurface is dropped (a counted
    warning).

Where a closure input needs arithmetic on linked values (roughness r -> GGX alpha r^2, the glass
layer's (1 - m) t, the Specular IOR, a Mix's clamped factor and its emission weights) the exporter
adds synthetic Math / Vector Math nodes to the table ("~..." ids); constants are folded here.
The core's Mix takes its emission from the mix itself, not from its parts: emission inside a
Mix or Add is lifted into the mix, weighted like the BSDFs (colour x strength x weight).
A mix's components are other materials of the table ("<material>/<node>/<a|b>"); each
material object carries the part of the node table its own inputs reach (scene-format:
links resolve against the table of the material object they appear in).

A Transparent BSDF of any colour, alone or in a Mix, is the core's `transparent` closure, as
Cycles 3.4 keeps it: camera and bounce paths pick it by its mix weight (a transparent bounce,
counted against Light Paths > Transparent only), next-event estimation lights the other closures
at every hit, and shadow rays pass filtered by its weight, up to Light Paths > Transparent
bounces. (It was once a stochastic coverage cut-out for a white one: noisier, docs/blender.md.)
Principled BSDF's Alpha a is Cycles 3.4's: a Mix Shader (factor a) of a white Transparent BSDF and
the Principled BSDF with its emission (shader_nodes.cpp PrincipledBsdfNode::expand), the same mix.
Normals are per closure, as Cycles' closures each have their own (the `normal` key: a link to a
Normal Map or Bump node, or any vector output).

Approximations, each one counted warning naming the material and the node:
  - a node the core does not evaluate (export/nodes.py SUPPORTED): the input it feeds keeps its
    own value;
  - a closure the core lacks (Toon, Hair, Subsurface Scattering, ...): 0.8 grey diffuse.
Dispersion comes from the material's gradphoton panel.
"""

import sys

from .nodes import NodeGraph, SHADER
from .volume import export_volume, volume_socket

DEFAULT = "__gradphoton_default"
GREY = {"type": "diffuse", "color": 0.8}



# Blender 3.4's Distribution enum -> the core's `distribution` (material.h Microfacet); GGX is
# the core's default. Sharp is alpha 0 whatever the Roughness. Cycles 3.4 compiles it to GGX at 0
# while Filter Glossy is on (shader_nodes.cpp simplify_settings: blurred like any GGX), unless its
# Roughness is linked to a value that does not fold to a constant: then it stays the singular
# closure, never blurred (the core's "sharp", Material::sharp). Measured in Blender 3.4.1: Sharp
# and GGX at 0 render bit for bit alike under Filter Glossy 1; Sharp with a Noise Texture on
# Roughness renders as Sharp without the filter.
_DISTRIBUTIONS = {'BECKMANN': "beckmann", 'ASHIKHMIN_SHIRLEY': "ashikhmin_shirley", 'MULTI_GGX': "multi_ggx"}


def _distribution(d, node):
    distribution = getattr(node, "distribution", 'GGX')
    if distribution == 'SHARP':
        linked = _is_link(d.get("roughness"))
        d["roughness"] = 0.0
        if linked and d.get("type") in ("conductor", "dielectric", "refraction"):
            d["distribution"] = "sharp"
        return
    name = _DISTRIBUTIONS.get(distribution)
    if name is not None:
        d["distribution"] = name
    elif distribution == 'GGX' and d.get("type") in ("conductor", "principled"):
        # Cycles 3.4's GGX reflection (bsdf_microfacet.h eval_reflect, Glossy and Principled's
        # specular and metal lobes) masks by the separable G1(wo) G1(wi), not the core's default
        # height-correlated G.
        d["masking"] = "separable"


def _is_link(v):
    return isinstance(v, dict)


def _positive(v):
    """False when a constant colour/number is surely zero (links may be anything)."""
    if _is_link(v):
        return True
    if isinstance(v, list):
        return any(c > 0 for c in v)
    return v > 0


def surface_output(tree):
    """The Material Output Cycles renders (Blender's ntreeShaderOutputNode for SHD_OUTPUT_CYCLES:
    a Cycles-only output wins over an All one, the active one among equals)."""
    best = None
    for n in tree.nodes:
        if n.bl_idname != 'ShaderNodeOutputMaterial' or n.target not in {'ALL', 'CYCLES'}:
            continue
        if best is None or (best.target == 'ALL' and n.target == 'CYCLES'):
            best = n
        elif best.target == n.target and n.is_active_output and not best.is_active_output:
            best = n
    return best


class MaterialExporter:
    def __init__(self, table, warnings, media=None):
        self.table = table  # name -> scene-format material dict
        self.media = media if media is not None else {}  # name -> scene-format medium (Volume outputs)
        self.w = warnings
        self._textured = set()  # exported materials that read UVs (their meshes need them)
        self._attributes = {}   # material name -> attribute names its nodes read ("" = render colour)

    def needs_uvs(self, mat):
        """True when Blender material `mat` reads the UV map (its meshes must export UVs)."""
        return mat is not None and mat.name in self._textured

    def attributes_read(self, mat):
        """Names of the mesh attributes Blender material `mat` reads ("" is the render colour)."""
        return self._attributes.get(mat.name, frozenset()) if mat is not None else frozenset()

    def name_for(self, mat, flags=None):
        """The core's material name for a Blender material (None: the default grey), with an
        object's visibility flags (export/visibility.py) as a variant of it."""
        if mat is None:
            if DEFAULT not in self.table:
                self.table[DEFAULT] = {"type": "diffuse", "color": 0.8}
            name = DEFAULT
        else:
            name = mat.name
            if name not in self.table:
                self.table[name] = self.convert(mat)
        if not flags:
            return name
        variant = name + " [" + ", ".join(f"{k}={v}" for k, v in sorted(flags.items())) + "]"
        if variant not in self.table:
            self.table[variant] = dict(self.table[name], **flags)
        return variant

    # ---- conversion ----

    def convert(self, mat):
        if not mat.use_nodes or mat.node_tree is None:
            c = mat.diffuse_color
            return self._dispersion({"type": "diffuse", "color": [c[0], c[1], c[2]]}, mat)
        self.g = NodeGraph(mat.name, self.w)
        self.mat = mat
        self.parts = []
        # Links are followed recursively: a chain of a few thousand nodes (the core's limit is
        # 4096) needs more than Python's default depth; deeper still is a warning, not a crash.
        limit = sys.getrecursionlimit()
        sys.setrecursionlimit(max(limit, 40000))
        try:
            return self._convert_tree(mat)
        except RecursionError:
            self.w.add("node graph too deep (rendered as 0.8 grey diffuse)", f"'{mat.name}'")
            for part in self.parts:
                part.clear()
                part.update(GREY)
            return dict(GREY)
        finally:
            sys.setrecursionlimit(limit)

    def _convert_tree(self, mat):
        out = surface_output(mat.node_tree)
        src = self.g.resolve(out.inputs["Surface"], ()) if out is not None else None
        has_surface = not (src is None or getattr(src, "kind", None) != SHADER or src.node is None)
        # The Volume output: the medium inside the material's closed meshes (export/volume.py).
        medium = None
        socket = volume_socket(mat.node_tree, 'ShaderNodeOutputMaterial')
        if socket is not None:
            medium = export_volume(socket, f"material '{mat.name}'", self.w, keep_empty=not has_surface)
        if not has_surface:
            if medium is not None:  # a volume without a surface: a pass-through boundary (Cycles)
                self.media[mat.name] = medium
                return {"type": "volume", "interior": mat.name}
            return {"type": "diffuse", "color": 0.0}  # Cycles renders an unconnected output black
        d = self._one_sided(self._dispersion(self._closure(src.node, src.path, 0), mat), mat)
        if medium is not None:
            self.media[mat.name] = medium
            d["interior"] = mat.name
        # Each material object carries the nodes its own inputs reach.
        uv = False
        for part in [d] + self.parts:
            nodes = self.g.table_for(part)
            if nodes:
                part["nodes"] = nodes
                uv = uv or self.g.reads_uv(nodes)
                self._attributes[mat.name] = self._attributes.get(mat.name, frozenset()) | self.g.attributes_read(nodes)
        if uv:
            self._textured.add(mat.name)
        return d

    def _in(self, node, path, name):
        """A closure input: a constant or a link into the table (None: nothing, e.g. a Normal)."""
        return self.g.value(node.inputs[name], path, label=f"{node.name} {name}")

    def _num(self, node, path, name):
        v = self._in(node, path, name)
        return 0.0 if v is None else v

    def _clamp01(self, v, hint):
        return self.g.math("ADD", v, 0.0, clamp=True, hint=hint)

    def _square(self, r, hint):
        """Blender roughness r -> GGX alpha r^2 (r clamped to [0, 1] first, as Cycles)."""
        c = self._clamp01(r, hint)
        return self.g.math("MULTIPLY", c, c, hint=hint)

    def _with_normal(self, d, node, path):
        if "Normal" in node.inputs:
            n = self._in(node, path, "Normal")
            if _is_link(n):
                d["normal"] = n
        return d

    def _nid(self, node, path):
        return self.g.node_id(node, path)

    def _part(self, d, node, path, label):
        """Registers `d`, a component of the material, in the table; returns its name."""
        name = f"{self.mat.name}/{self._nid(node, path)}/{label}"
        self.table[name] = d
        self.parts.append(d)
        return name

    def _closure(self, node, path, depth):
        """The scene-format material of one closure node (recursing into Mix/Add Shader)."""
        kind = node.bl_idname
        mat = self.mat
        if depth > 16:
            self.w.add("shader nodes nested too deep rendered as grey diffuse", f"'{mat.name}': {node.name}")
            return dict(GREY)
        if kind == 'ShaderNodeBsdfPrincipled':
            return self._principled(node, path)
        if kind == 'ShaderNodeBsdfDiffuse':  # Roughness: Cycles' Oren-Nayar sigma, as it is (not squared)
            return self._with_normal({"type": "diffuse", "color": self._in(node, path, "Color"),
                                      "roughness": self._clamp01(self._num(node, path, "Roughness"), "sigma")},
                                     node, path)
        if kind == 'ShaderNodeBsdfTransparent':  # straight through, tinted (a delta closure)
            return {"type": "transparent", "color": self._in(node, path, "Color")}
        if kind == 'ShaderNodeBsdfTranslucent':
            return self._with_normal({"type": "translucent", "color": self._in(node, path, "Color")}, node, path)
        if kind == 'ShaderNodeBsdfVelvet':
            sigma = self._num(node, path, "Sigma")
            if _is_link(sigma):  # the core reads a constant sigma
                self.w.add("linked Velvet Sigma uses its own value", f"'{mat.name}': {self._nid(node, path)}")
                sigma = node.inputs["Sigma"].default_value
            return self._with_normal({"type": "velvet", "color": self._in(node, path, "Color"),
                                      "sigma": min(1.0, max(0.0, sigma))}, node, path)
        glossy = kind in ('ShaderNodeBsdfGlossy', 'ShaderNodeBsdfAnisotropic')
        if glossy:
            # Cycles' Glossy BSDF: the colour at every angle (no Fresnel).
            d = {"type": "conductor", "color": self._in(node, path, "Color"),
                 "roughness": self._square(self._num(node, path, "Roughness"), "alpha"), "fresnel": False}
            _distribution(d, node)
            if "Anisotropy" in node.inputs:  # the Anisotropic BSDF (Cycles' convention, the core's)
                self._anisotropy(d, node, path, self._num(node, path, "Anisotropy"), "Rotation")
            return self._with_normal(d, node, path)
        if kind in ('ShaderNodeBsdfGlass', 'ShaderNodeBsdfRefraction'):
            # Refraction BSDF: glass's refraction lobe alone, without Fresnel (the core's "refraction").
            d = {"type": "dielectric" if kind == 'ShaderNodeBsdfGlass' else "refraction",
                 "color": self._in(node, path, "Color"),
                 "roughness": self._square(self._num(node, path, "Roughness"), "alpha"),
                 "ior": self.g.math("MAXIMUM", self._num(node, path, "IOR"), 1e-3, hint="ior")}
            _distribution(d, node)
            if kind == 'ShaderNodeBsdfGlass' and d.get("distribution") != "multi_ggx":
                # Cycles 3.4 (svm/closure.h) splits Glass of GGX, Beckmann and Sharp into a reflection
                # and a refraction closure weighted by the Fresnel at the shading normal, F and 1 - F;
                # Multiscatter GGX glass stays one closure with its Fresnel per microfacet.
                d["fresnel"] = "normal"
            return self._with_normal(d, node, path)
        if kind == 'ShaderNodeHoldout':
            # Cycles' Holdout closure: the surface is cut out of the image (no colour, alpha 0) where
            # the camera sees it. Inside a Mix or Add it is a black part weighted by the mix, and
            # its weight becomes the material's `holdout` (_mix): alpha 1 - weight.
            return {"type": "emission", "strength": 0.0, "holdout": True}
        if kind == 'ShaderNodeEmission':
            return {"type": "emission", "emission": self._in(node, path, "Color"),
                    "strength": self.g.math("MAXIMUM", self._num(node, path, "Strength"), 0.0, hint="strength"),
                    "two_sided": True}
        if kind in ('ShaderNodeMixShader', 'ShaderNodeAddShader'):
            return self._mix(node, path, depth)
        self.w.add("closure not supported (rendered as 0.8 grey diffuse)", f"'{mat.name}': {self._nid(node, path)}")
        return dict(GREY)

    def _anisotropy(self, d, node, path, anisotropy, rotation_name):
        """Anisotropy (Cycles' Anisotropic BSDF convention), its Rotation and Tangent on `d`."""
        if not _positive(anisotropy) and not (isinstance(anisotropy, (int, float)) and anisotropy < 0):
            return
        if d.get("distribution") == "ashikhmin_shirley":
            self.w.add("anisotropic Ashikhmin-Shirley rendered isotropic", f"'{self.mat.name}': {self._nid(node, path)}")
            return
        d["anisotropy"] = anisotropy
        rotation = self._num(node, path, rotation_name)
        if _is_link(rotation) or rotation != 0.0:
            d["rotation"] = rotation
        tangent = self._in(node, path, "Tangent")
        if _is_link(tangent):
            d["tangent"] = tangent

    def _shader_in(self, socket, path):
        """The closure node feeding a shader socket, as (node, path), or None."""
        src = self.g.resolve(socket, path)
        if src is None or getattr(src, "kind", None) != SHADER or src.node is None:
            return None
        return src.node, src.path

    def _sub(self, pair, depth):
        # An unconnected shader socket is no closure: black, as in Cycles.
        return self._closure(pair[0], pair[1], depth + 1) if pair is not None else {"type": "emission", "strength": 0.0}

    def _emission_term(self, d):
        """colour x strength of a part's emission ([r, g, b] or a link), or None when surely zero."""
        if "emission" not in d or "strength" not in d:
            return None
        e, s = d["emission"], d["strength"]
        if e is None or not _positive(e) or not _positive(s):
            return None
        return self.g.vector_math("SCALE", e, scale=s, hint="emission")

    def _mix(self, node, path, depth):
        add = node.bl_idname == 'ShaderNodeAddShader'
        if add:
            sockets = (node.inputs[0], node.inputs[1])
            weights = (1.0, 1.0)
            t = None
        else:
            # Cycles clamps a Mix Shader's factor to [0, 1] (svm_node_mix_closure).
            t = self._clamp01(self._num(node, path, "Fac"), "fac")
            sockets = (node.inputs[1], node.inputs[2])
            weights = (self.g.math("SUBTRACT", 1.0, t, clamp=True, hint="fac"), t)
        pairs = [self._shader_in(s, path) for s in sockets]
        parts = [self._sub(p, depth) for p in pairs]
        return self._combine(parts, weights, t, node, path, ("a", "b"))

    def _combine(self, parts, weights, t, node, path, labels):
        """The core's mix (t: its factor) or add (t None) of two parts with their weights: holdout
        and emission lifted into it, weighted (the Mix / Add Shader, and Principled Alpha's mix)."""
        add = t is None
        holdout = self._holdout_weight(parts, weights)
        # Emission inside a mix, weighted like the BSDFs, is carried by the mix itself (the
        # core takes a mix's emission from the mix, not from its parts).
        emission = None
        for d, w in zip(parts, weights):
            term = self._emission_term(d)
            if term is not None and _positive(w):
                term = term if w == 1.0 else self.g.vector_math("SCALE", term, scale=w, hint="emission")
                emission = term if emission is None else self.g.vector_math("ADD", emission, term, hint="emission")
            for key in ("emission", "strength", "two_sided"):
                d.pop(key, None)
        out = {"type": "add" if add else "mix",
               "a": self._part(parts[0], node, path, labels[0]), "b": self._part(parts[1], node, path, labels[1])}
        if not add:
            out["factor"] = t
        if emission is not None and _positive(emission):
            out.update({"emission": emission, "strength": 1.0, "two_sided": True})
        if holdout is not None:
            out["holdout"] = holdout
        return out

    def _holdout_weight(self, parts, weights):
        """The holdout weight of a Mix / Add Shader, taken out of its parts: each part's (True: 1)
        times its weight, summed, as Cycles sums its holdout closures' weights (svm_node_closure_holdout
        allocates one with the mix weight; shader_holdout_apply adds them). True for a constant 1
        or more (the whole surface), a number in (0, 1), a link (the core clamps it), None for none."""
        total = None
        for d, w in zip(parts, weights):
            h = d.pop("holdout", None)
            if h is None or h is False:
                continue
            term = w if h is True else h if w == 1.0 else self.g.math("MULTIPLY", h, w, hint="holdout")
            total = term if total is None else self.g.math("ADD", total, term, hint="holdout")
        if total is None or _is_link(total):
            return total
        return True if total >= 1.0 else total if total > 0.0 else None

    @staticmethod
    def _one_sided(d, mat):
        gp = getattr(mat, "gradphoton", None)
        if gp is not None and gp.emission_one_sided and "strength" in d:
            d["two_sided"] = False
        return d

    def _principled(self, node, path):
        g, mat = self.g, self.mat
        nid = self._nid(node, path)
        base = self._in(node, path, "Base Color")
        alpha = self._square(self._num(node, path, "Roughness"), "alpha")  # GGX alpha = r^2
        metallic = self._clamp01(self._num(node, path, "Metallic"), "metallic")
        trans = self._clamp01(self._num(node, path, "Transmission"), "transmission")
        # Cycles: F0 = 0.08 Specular for the specular lobe: IOR (1 + sqrt F0) / (1 - sqrt F0)
        # (Specular 0: IOR 1, no specular reflection, the Burley diffuse alone).
        spec = g.math("MAXIMUM", self._num(node, path, "Specular"), 0.0, hint="specular")
        sf0 = g.math("MINIMUM", g.math("SQRT", g.math("MULTIPLY", spec, 0.08, hint="specular"), hint="specular"),
                     0.99, hint="specular")
        ior = g.math("DIVIDE", g.math("ADD", 1.0, sf0, hint="specular"), g.math("SUBTRACT", 1.0, sf0, hint="specular"),
                     hint="specular")
        d = self._with_normal({"type": "principled", "color": base, "roughness": alpha, "ior": ior}, node, path)
        _distribution(d, node)  # Cycles 3.4: the specular, metal and glass lobes' (GGX, Multiscatter GGX)
        # Cycles' Specular Tint and Sheen (+ Sheen Tint) belong to the non-metal part: the tint of
        # its specular lobe and a sheen lobe weighted like its diffuse one (svm_closure.h).
        spec_tint = self._clamp01(self._num(node, path, "Specular Tint"), "specular_tint")
        if _positive(spec_tint):
            d["specular_tint"] = spec_tint
        sheen = g.math("MAXIMUM", self._num(node, path, "Sheen"), 0.0, hint="sheen")
        if _positive(sheen):
            d["sheen"] = sheen
            d["sheen_tint"] = self._clamp01(self._num(node, path, "Sheen Tint"), "sheen_tint")
        s = node.inputs.get("Subsurface")
        if s is not None and _positive(self._num(node, path, "Subsurface")):
            self.w.add("Principled BSDF Subsurface dropped", f"'{mat.name}': {nid}")
        # Cycles' one specular closure of the metal: cspec0 = base colour, interpolated toward white
        # by the dielectric Fresnel of the same Specular-derived IOR (bsdf_util.h).
        metal = self._with_normal({"type": "conductor", "color": base, "roughness": alpha, "fresnel": "principled",
                                   "ior": ior}, node, path)
        _distribution(metal, node)
        # Anisotropic a: Cycles' aspect sqrt(1 - 0.9 a) gives alpha_x = alpha / aspect, alpha_y =
        # alpha aspect, which is the Anisotropic BSDF's convention with anisotropy aspect - 1.
        aniso = self._num(node, path, "Anisotropic")
        if _positive(aniso):
            a = self._clamp01(aniso, "anisotropy")
            aniso = g.math("SUBTRACT", g.math("SQRT", g.math("SUBTRACT", 1.0, g.math("MULTIPLY", a, 0.9, hint="anisotropy"),
                                                             hint="anisotropy"), hint="anisotropy"), 1.0, hint="anisotropy")
            for part in (d, metal):
                self._anisotropy(part, node, path, aniso, "Anisotropic Rotation")
        if not _is_link(metallic) and metallic >= 1.0:
            d = metal
        elif _positive(metallic):
            d = {"type": "mix", "a": self._part(d, node, path, "plastic"), "b": self._part(metal, node, path, "metal"),
                 "factor": metallic}
        t_glass = g.math("MULTIPLY", g.math("SUBTRACT", 1.0, metallic, hint="glass"), trans, hint="glass")
        glass = self._with_normal({"type": "dielectric", "color": base, "roughness": alpha,
                                   "ior": g.math("MAXIMUM", self._num(node, path, "IOR"), 1e-3, hint="ior")},
                                  node, path)
        _distribution(glass, node)
        # Cycles 3.4 (svm_closure.h, principled): single-scatter GGX glass (GGX, or any distribution
        # at Roughness <= 0.05) is a reflection closure weighted by the Fresnel at the shading
        # normal and a refraction closure weighted by 1 - that (as the Glass BSDF); Multiscatter
        # GGX glass above 0.05 is one closure with its Fresnel per microfacet.
        r = self._num(node, path, "Roughness")
        if glass.get("distribution") == "multi_ggx" and not _is_link(r) and r <= 5e-2:
            del glass["distribution"]
        if glass.get("distribution") != "multi_ggx":
            glass["fresnel"] = "normal"
        # Cycles 3.4 (svm/closure.h): the Base Color weights Principled glass's refraction only; its
        # reflection is white, tinted toward the Base Color by Specular Tint through the Fresnel
        # blend (cspec0). The dielectric's "specular_tint" asks for that (the Glass BSDF tints both).
        glass["specular_tint"] = spec_tint
        if not _is_link(t_glass) and t_glass >= 1.0:
            d = glass
        elif _positive(t_glass):
            d = {"type": "mix", "a": self._part(d, node, path, "opaque"), "b": self._part(glass, node, path, "glass"),
                 "factor": t_glass}
        # Clearcoat: Cycles' own closure, weighted by the closure weight alone (not by Metallic or
        # Transmission), with its own normal: added to the rest.
        clearcoat = g.math("MAXIMUM", self._num(node, path, "Clearcoat"), 0.0, hint="clearcoat")
        if _positive(clearcoat):
            coat = {"type": "clearcoat", "clearcoat": clearcoat,
                    "roughness": self._square(self._num(node, path, "Clearcoat Roughness"), "alpha")}
            n = self._in(node, path, "Clearcoat Normal")
            if _is_link(n):
                coat["normal"] = n
            d = {"type": "add", "a": self._part(d, node, path, "base"), "b": self._part(coat, node, path, "clearcoat")}
        emission = self._in(node, path, "Emission")
        strength = self._num(node, path, "Emission Strength")
        if _positive(strength) and _positive(emission):
            d = dict(d, emission=emission, strength=g.math("MAXIMUM", strength, 0.0, hint="strength"), two_sided=True)
        # Alpha a: Cycles 3.4 makes the Principled BSDF (its emission included) the second closure of
        # a Mix Shader of factor a whose first is a white Transparent BSDF, where Alpha is linked or
        # below 1 (shader_nodes.cpp PrincipledBsdfNode::expand; the mix clamps a to [0, 1]). The
        # core's mix with a transparent closure is exactly that, in every method: paths pick the
        # Transparent BSDF by its weight 1 - a (a transparent bounce), shadow rays pass filtered by
        # it. (It was a stochastic coverage cut-out, the core's `alpha`.)
        a = self._clamp01(self._num(node, path, "Alpha"), "alpha")
        if _is_link(a) or a < 1.0:
            clear = {"type": "transparent", "color": [1.0, 1.0, 1.0]}
            d = self._combine([clear, d], (g.math("SUBTRACT", 1.0, a, clamp=True, hint="alpha"), a), a, node, path,
                              ("transparent", "surface"))
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
