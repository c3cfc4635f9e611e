"""Node graphs: a Blender shader tree -> the scene format's node table (docs/scene-format.md,
"Node graphs"), read as Cycles 3.4 reads the tree (intern/cycles/blender/shader.cpp, add_nodes):

  - node groups are flattened: a group node's output is the active Group Output's input inside
    it, a Group Input's output is the group node's input outside; nested groups too. Node ids
    are Blender's node names prefixed by the group path ("Group/Inner/Noise Texture");
  - reroutes are removed and muted nodes replaced by their internal links (an output without
    one feeds nothing: the input it is linked to keeps its own value, as Cycles drops the link);
  - links that are invalid, muted, or from or to an unavailable socket are ignored;
  - at a group's sockets and a muted node's internal link Cycles puts a conversion to the
    socket's type: a colour or vector meeting a float socket there is turned into a float by a
    synthetic Math node (the core converts it at the Math node's input: colour -> luminance,
    vector -> average); the other conversions keep every component the consumer reads;
  - Value and RGB nodes are folded into the constants they feed (converted to the consuming
    socket's type as Blender converts);
  - only what the closures read is written: each input is its constant (default_value) or a
    {"link": id, "output": identifier}; unlinked inputs without a value of their own (a
    texture's Vector, a Normal) are left out: the core uses Blender's implicit default.

A node type the core does not evaluate (not in SUPPORTED) is never written: the input it feeds
keeps its own value, with one counted warning naming the material and the node.
"""
import bpy

from .texture import image_file

# Non-closure node types the core evaluates (native/shading). The one list in the addon: a node
# of any other type is reported and left out. Keep in step with the core's list
# (tests/blender/test_nodes.py compares the two when the core exposes its list).
SUPPORTED = frozenset({
    # textures
    "ShaderNodeTexImage", "ShaderNodeTexChecker", "ShaderNodeTexNoise", "ShaderNodeTexVoronoi",
    "ShaderNodeTexMusgrave", "ShaderNodeTexWave", "ShaderNodeTexGradient", "ShaderNodeTexMagic",
    "ShaderNodeTexBrick", "ShaderNodeTexWhiteNoise", "ShaderNodeTexEnvironment", "ShaderNodeTexSky",
    # colour
    "ShaderNodeMixRGB", "ShaderNodeMix", "ShaderNodeValToRGB", "ShaderNodeRGBCurve", "ShaderNodeHueSaturation",
    "ShaderNodeInvert", "ShaderNodeGamma", "ShaderNodeBrightContrast", "ShaderNodeRGBToBW",
    # converter
    "ShaderNodeMath", "ShaderNodeVectorMath", "ShaderNodeMapRange", "ShaderNodeClamp",
    "ShaderNodeSeparateRGB", "ShaderNodeCombineRGB", "ShaderNodeSeparateXYZ", "ShaderNodeCombineXYZ",
    "ShaderNodeSeparateHSV", "ShaderNodeCombineHSV", "ShaderNodeSeparateColor", "ShaderNodeCombineColor",
    "ShaderNodeBlackbody", "ShaderNodeWavelength", "ShaderNodeFloatCurve", "ShaderNodeVectorCurve",
    # input
    "ShaderNodeTexCoord", "ShaderNodeUVMap", "ShaderNodeNewGeometry", "ShaderNodeObjectInfo",
    "ShaderNodeFresnel", "ShaderNodeLayerWeight", "ShaderNodeLightPath", "ShaderNodeVertexColor",
    "ShaderNodeAttribute",
    # vector
    "ShaderNodeMapping", "ShaderNodeNormalMap", "ShaderNodeBump", "ShaderNodeVectorTransform",
})
# Folded by the exporter into the constants they feed (never written).
CONSTANT_NODES = frozenset({"ShaderNodeValue", "ShaderNodeRGB"})
# Nodes whose evaluation reads the mesh's UV map (directly, as an image's default coordinates,
# or for tangents): meshes with such a material export their UVs.
READS_UV = frozenset({"ShaderNodeTexImage", "ShaderNodeTexCoord", "ShaderNodeUVMap", "ShaderNodeNormalMap"})
# Over this many nodes the core refuses a graph; the exporter stops there too.
MAX_NODES = 4096

VALUE, VECTOR, RGBA, SHADER = 'VALUE', 'VECTOR', 'RGBA', 'SHADER'
# Rec.709 luminance, as Cycles' RGB-to-BW (kernel/svm/convert.h with the default config).
LUMINANCE = (0.2126, 0.7152, 0.0722)
MISSING_IMAGE = (1.0, 0.0, 1.0)  # Cycles' colour of a missing image (TEX_IMAGE_MISSING_R/G/B)

_BASE_PROPS = None  # properties every shader node has (name, label, location, ...): not written
_SKIPPED_PROPS = {"texture_mapping", "color_mapping", "image_user", "script", "filepath", "bytecode",
                  "bytecode_hash", "internal_links"}


def kind_of(socket):
    """A socket's value kind as Cycles converts it (INT and BOOLEAN sockets are floats)."""
    t = socket.type
    if t in (VECTOR, RGBA, SHADER):
        return t
    return VALUE


class Const:
    """A constant arriving at an input: a float or a 3-tuple, of kind VALUE / VECTOR / RGBA."""
    __slots__ = ("value", "kind")

    def __init__(self, value, kind):
        self.value, self.kind = value, kind


class Out:
    """An output socket arriving at an input: of a Blender node (at a group path) or of a
    synthetic node already in the table (node None, id given)."""
    __slots__ = ("node", "socket", "path", "kind", "id")

    def __init__(self, node, socket, path, kind, id=None):
        self.node, self.socket, self.path, self.kind, self.id = node, socket, path, kind, id


def socket_value(socket):
    """A socket's own value as (value, kind), or None when it has none (closures, hidden values)."""
    if not hasattr(socket, "default_value") or socket.type == SHADER:
        return None
    k = kind_of(socket)
    v = socket.default_value
    if k == VALUE:
        return float(v), k
    return (float(v[0]), float(v[1]), float(v[2])), k


def convert(value, src, dst):
    """A constant converted between kinds as Blender/Cycles convert a link (kernel/svm/convert.h):
    colour -> float the Rec.709 luminance, vector -> float the average, float -> colour or vector
    a splat, colour <-> vector component-wise."""
    if src == dst or dst == SHADER:
        return value
    if dst == VALUE:
        if src == RGBA:
            return sum(w * c for w, c in zip(LUMINANCE, value))
        return (value[0] + value[1] + value[2]) / 3.0
    if src == VALUE:
        return (value, value, value)
    return tuple(value)


def to_json(value):
    if isinstance(value, tuple):
        return [float(c) for c in value]
    return float(value)


def describe(value):
    """A constant in a warning: '0.8', '0.8 grey', '(1, 0, 0)'."""
    if isinstance(value, (tuple, list)):
        if max(value) - min(value) < 1e-6:
            return f"{value[0]:.3g} grey"
        return "(" + ", ".join(f"{c:.3g}" for c in value) + ")"
    return f"{value:.3g}"


def _props_of_rna():
    global _BASE_PROPS
    if _BASE_PROPS is None:
        _BASE_PROPS = {p.identifier for p in bpy.types.ShaderNode.bl_rna.properties}
    return _BASE_PROPS


def _color_ramp(ramp):
    return {"interpolation": ramp.interpolation, "color_mode": ramp.color_mode,
            "hue_interpolation": ramp.hue_interpolation,
            "elements": [{"position": float(e.position), "color": [float(c) for c in e.color]}
                         for e in ramp.elements]}


CURVE_SAMPLES = 256  # as Cycles' curve tables (RAMP_TABLE_SIZE)


def _curve_mapping(mapping):
    """A CurveMapping as sampled points per curve, over the x range of all its curves' end
    points (Cycles' curvemapping_minmax); the core interpolates them linearly, as Cycles' table."""
    mapping.update()
    curves = list(mapping.curves)
    lo = min(c.points[0].location[0] for c in curves)
    hi = max(c.points[-1].location[0] for c in curves)
    if not hi > lo:
        hi = lo + 1.0
    xs = [lo + (hi - lo) * i / (CURVE_SAMPLES - 1) for i in range(CURVE_SAMPLES)]
    return {"curves": [[[x, float(mapping.evaluate(c, x))] for x in xs] for c in curves],
            "extend": mapping.extend}


class NodeGraph:
    """The node table of one Blender node tree (a material's), filled as the closures' inputs
    are read; Warnings shared with the exporter."""

    def __init__(self, owner_name, warnings):
        self.owner = owner_name        # the material's name, for warnings
        self.w = warnings
        self.nodes = {}                # id -> scene-format node
        self._busy = set()             # ids being written (a cycle guard; Blender marks cycles invalid)
        self._synthetic = 0
        self._link_index = {}          # node tree -> {input socket -> links Cycles follows}

    # ---- following links ----

    def _links_into(self, socket):
        """Links into an input that Cycles follows: valid, not muted, both sockets available.
        (socket.links walks the whole tree each time: the tree's links are indexed once.)"""
        if not socket.is_linked:
            return []
        tree = socket.id_data
        index = self._link_index.get(tree.as_pointer())
        if index is None:
            index = {}
            for link in tree.links:
                if link.is_valid and not link.is_muted and link.from_socket.enabled and link.to_socket.enabled:
                    index.setdefault(link.to_socket.as_pointer(), []).append(link)
            self._link_index[tree.as_pointer()] = index
        return index.get(socket.as_pointer(), [])

    def resolve(self, socket, path):
        """What arrives at input `socket` of a node in the tree at group path `path`: a Const,
        an Out, or None (nothing: the input's own value applies)."""
        links = self._links_into(socket)
        if not links:
            own = socket_value(socket)
            return Const(*own) if own is not None and not socket.hide_value else None
        link = links[0]
        return self._output(link.from_node, link.from_socket, path)

    def _through(self, socket, path, kind):
        """resolve(socket, path) seen through a conversion to `kind` (a group socket or a muted
        node's internal link: Cycles' ConvertNode proxies)."""
        src = self.resolve(socket, path)
        if src is None:
            return None
        if isinstance(src, Const):
            return Const(convert(src.value, src.kind, kind), kind)
        if kind == VALUE and src.kind in (RGBA, VECTOR):
            return self._to_float(src)
        return Out(src.node, src.socket, src.path, kind if kind != SHADER else src.kind, src.id)

    def _output(self, node, socket, path):
        kind = kind_of(socket)
        t = node.bl_idname
        if t == 'NodeReroute':
            return self._through(node.inputs[0], path, kind)
        if node.mute:
            for il in node.internal_links:
                if il.to_socket == socket:
                    return self._through(il.from_socket, path, kind)
            return None  # Cycles maps no proxy: the link is dropped
        if t == 'ShaderNodeGroup' or t == 'NodeCustomGroup':
            tree = node.node_tree
            if tree is None:
                return None
            gout = next((n for n in tree.nodes if n.bl_idname == 'NodeGroupOutput' and n.is_active_output), None)
            inner = next((s for s in gout.inputs if s.identifier == socket.identifier), None) if gout else None
            if inner is None:  # Cycles' proxy with nothing connected: zero
                return Const(convert(0.0, VALUE, kind), kind)
            return self._through(inner, path + (node,), kind)
        if t == 'NodeGroupInput':
            if not path:
                return None
            group = path[-1]
            outer = next((s for s in group.inputs if s.identifier == socket.identifier), None)
            if outer is None:
                return None
            return self._through(outer, path[:-1], kind_of(outer))
        if t == 'ShaderNodeValue':
            return Const(float(node.outputs[0].default_value), VALUE)
        if t == 'ShaderNodeRGB':
            v = node.outputs[0].default_value
            return Const((float(v[0]), float(v[1]), float(v[2])), RGBA)
        return Out(node, socket, path, kind)

    # ---- writing ----

    @staticmethod
    def node_id(node, path):
        return "/".join([g.name for g in path] + [node.name])

    def value(self, socket, path, label=None):
        """The scene-format value of input `socket` (a node's at group path `path`): a number,
        [r, g, b], {"link": id, "output": identifier}, or None when it has no value of its own
        and nothing arrives. `label` names the input in warnings."""
        own = socket_value(socket)
        dst = kind_of(socket)
        src = self.resolve(socket, path)
        if src is None:
            return None if own is None or socket.hide_value else to_json(own[0])
        if isinstance(src, Const):
            return to_json(convert(src.value, src.kind, dst))
        if src.id is not None:
            return {"link": src.id, "output": src.socket}
        node = src.node
        t = node.bl_idname
        if src.kind == SHADER:
            return None if own is None else to_json(own[0])
        if t in ('ShaderNodeTexImage', 'ShaderNodeTexEnvironment'):
            path_or_none, why = image_file(node.image)
            if path_or_none is None:
                label_img = node.image.name if node.image is not None else self.node_id(node, src.path)
                self.w.add("image texture missing (magenta)", f"'{self.owner}': {label_img} ({why})")
                missing = 1.0 if src.socket.identifier == "Alpha" else MISSING_IMAGE
                return to_json(convert(missing, VALUE if src.socket.identifier == "Alpha" else RGBA, dst))
        if t not in SUPPORTED:
            where = label or f"{socket.node.name} {socket.name}"
            keeps = f"{where} uses {describe(own[0])}" if own is not None else f"{where} unset"
            self.w.add("node not supported (the input it feeds keeps its own value)",
                       f"'{self.owner}': {self.node_id(node, src.path)} ({keeps})")
            return None if own is None or socket.hide_value and not socket.is_linked else to_json(own[0])
        nid = self.write(node, src.path)
        if nid is None:
            return None if own is None else to_json(own[0])
        return {"link": nid, "output": src.socket.identifier}

    def write(self, node, path):
        """Writes a Blender node (and what feeds it) into the table; returns its id (None when
        the table is full)."""
        nid = self.node_id(node, path)
        if nid in self.nodes or nid in self._busy:
            return nid
        if len(self.nodes) >= MAX_NODES:
            self.w.add(f"node graph over {MAX_NODES} nodes (the rest left out)", f"'{self.owner}'")
            return None
        self._busy.add(nid)
        entry = {"type": node.bl_idname}
        props = self._props(node)
        if props:
            entry["props"] = props
        inputs = {}
        for s in node.inputs:
            if not s.enabled:
                continue
            v = self.value(s, path)
            if v is not None:
                inputs[s.identifier] = v
        if inputs:
            entry["inputs"] = inputs
        self._busy.discard(nid)
        self.nodes[nid] = entry
        return nid

    def _props(self, node):
        base = _props_of_rna()
        out = {}
        for p in node.bl_rna.properties:
            k = p.identifier
            if k in base or k in _SKIPPED_PROPS:
                continue
            if p.type == 'ENUM' and not p.is_enum_flag:
                out[k] = getattr(node, k)
            elif p.type in ('BOOLEAN', 'INT', 'FLOAT', 'STRING') and not p.is_readonly:
                v = getattr(node, k)
                out[k] = list(v) if getattr(p, "is_array", False) else v
            elif k == "color_ramp" and node.color_ramp is not None:
                out[k] = _color_ramp(node.color_ramp)
            elif k == "mapping" and p.type == 'POINTER' and node.mapping is not None:
                out[k] = _curve_mapping(node.mapping)
            elif k == "object" and node.object is not None:
                # Object then reads through this object's inverse matrix (Cycles'
                # TextureCoordinateNode use_transform); the core inverts it.
                out["object_matrix"] = [list(row) for row in node.object.matrix_world]
        if node.bl_idname in ('ShaderNodeTexImage', 'ShaderNodeTexEnvironment'):
            img = node.image
            path, _ = image_file(img)
            out["image"] = path
            out["colorspace"] = img.colorspace_settings.name
            out["alpha_mode"] = img.alpha_mode
        return out

    # ---- synthetic nodes ----

    def synthetic(self, entry, output, kind, hint):
        """Adds a node the exporter made (a conversion, a Principled weight); returns its Out."""
        self._synthetic += 1
        nid = f"~{hint}.{self._synthetic}"
        self.nodes[nid] = entry
        return Out(None, output, (), kind, nid)

    def _to_float(self, src):
        """A colour or vector output as a float (a group socket or muted link of type float):
        a Math ADD of it and 0, the core converting the link as Cycles does."""
        ref = self._link_of(src)
        return self.synthetic({"type": "ShaderNodeMath", "props": {"operation": "ADD", "use_clamp": False},
                               "inputs": {"Value": ref, "Value_001": 0.0}}, "Value", VALUE, "to_float")

    def _link_of(self, src):
        if src.id is not None:
            return {"link": src.id, "output": src.socket}
        return {"link": self.write(src.node, src.path), "output": src.socket.identifier}

    def math(self, op, a, b=0.0, clamp=False, hint="math"):
        """Math node `op` of two inputs (numbers or links): folded when both are numbers."""
        if not isinstance(a, dict) and not isinstance(b, dict):
            return fold_math(op, a, b, clamp)
        out = self.synthetic({"type": "ShaderNodeMath", "props": {"operation": op, "use_clamp": clamp},
                              "inputs": {"Value": a, "Value_001": b}}, "Value", VALUE, hint)
        return {"link": out.id, "output": "Value"}

    def vector_math(self, op, a, b=None, scale=None, hint="vmath"):
        """Vector Math `op` (ADD or SCALE) on colours ([r, g, b] or links): folded when constant."""
        const = not isinstance(a, dict) and not isinstance(b, dict) and not isinstance(scale, dict)
        if const:
            a = a if isinstance(a, list) else [a] * 3
            if op == "SCALE":
                return [c * scale for c in a]
            b = b if isinstance(b, list) else [b] * 3
            return [x + y for x, y in zip(a, b)]
        inputs = {"Vector": a}
        if op == "SCALE":
            inputs["Scale"] = scale
        else:
            inputs["Vector_001"] = b
        out = self.synthetic({"type": "ShaderNodeVectorMath", "props": {"operation": op}, "inputs": inputs},
                             "Vector", VECTOR, hint)
        return {"link": out.id, "output": "Vector"}

    # ---- tables per material object ----

    def table_for(self, d):
        """The part of the table that material dict `d` reaches through its links."""
        todo = [v for v in _links_in(d)]
        seen = {}
        while todo:
            nid = todo.pop()
            if nid in seen or nid not in self.nodes:
                continue
            seen[nid] = self.nodes[nid]
            todo.extend(_links_in(self.nodes[nid].get("inputs", {})))
        return seen

    def reads_uv(self, table):
        return any(n["type"] in READS_UV for n in table.values())

    @staticmethod
    def attributes_read(table):
        """Names of the mesh attributes the table's Color Attribute / Attribute (Geometry) nodes
        read: the meshes export them. "" is the render colour attribute."""
        out = set()
        for n in table.values():
            props = n.get("props", {})
            if n["type"] == "ShaderNodeVertexColor":
                out.add(props.get("layer_name", ""))
            elif n["type"] == "ShaderNodeAttribute" and props.get("attribute_type", "GEOMETRY") == "GEOMETRY":
                if props.get("attribute_name"):
                    out.add(props["attribute_name"])
        return frozenset(out)


def _links_in(d):
    out = []
    for v in d.values():
        if isinstance(v, dict) and "link" in v:
            out.append(v["link"])
    return out


def fold_math(op, a, b, clamp):
    """Cycles' Math node on constants (kernel/svm/math_util.h: safe division and square root)."""
    if op == "ADD":
        r = a + b
    elif op == "SUBTRACT":
        r = a - b
    elif op == "MULTIPLY":
        r = a * b
    elif op == "DIVIDE":
        r = a / b if b != 0 else 0.0
    elif op == "SQRT":
        r = a ** 0.5 if a > 0 else 0.0
    elif op == "MINIMUM":
        r = min(a, b)
    elif op == "MAXIMUM":
        r = max(a, b)
    else:
        raise ValueError(op)
    return min(1.0, max(0.0, r)) if clamp else r
