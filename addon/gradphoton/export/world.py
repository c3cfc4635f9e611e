"""World: the Background node's colour x strength as constant environment radiance
(W sr^-1 m^-2, as Cycles), with World > Settings > Ray Visibility (export/visibility.py).
A node linked into the Background node (a texture, a Sky) is rendered as the value typed in
the socket it feeds: a warning naming the node and that value."""

from . import visibility


def export_world(world, warnings):
    env = _radiance(world, warnings)
    if env:
        env.update(visibility.world_flags(world, warnings))
    return env


def _radiance(world, warnings):
    if world is None:
        return None
    if not world.use_nodes or world.node_tree is None:
        c = world.color
        return {"color": [c[0], c[1], c[2]], "strength": 1.0}
    out = next((n for n in world.node_tree.nodes
                if n.bl_idname == 'ShaderNodeOutputWorld' and n.is_active_output), None)
    if out is None or not out.inputs["Surface"].is_linked:
        return None
    node = out.inputs["Surface"].links[0].from_node
    if node.bl_idname != 'ShaderNodeBackground':
        warnings.add("unsupported world shader (black environment)", f"'{world.name}': {node.name}")
        return None
    color, strength = node.inputs["Color"], node.inputs["Strength"]
    for s in (color, strength):
        if s.is_linked:  # name the node that feeds it and the value rendered instead
            src = s.links[0].from_node
            warnings.add("World node not rendered: its Background input renders with the value typed in it",
                         f"'{world.name}': {src.name} into Background {s.name} (rendered as {_value(s)})")
    c = color.default_value
    return {"color": [c[0], c[1], c[2]], "strength": max(0.0, strength.default_value)}


def _value(socket):
    """A socket's own value as the report shows it: 0.8, or (0.05, 0.05, 0.05) for a colour."""
    v = socket.default_value
    if isinstance(v, float):
        return f"{v:.3g}"
    return "(" + ", ".join(f"{x:.3g}" for x in tuple(v)[:3]) + ")"
