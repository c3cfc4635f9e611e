"""World: the Background node's colour x strength as constant environment radiance
(W sr^-1 m^-2, as Cycles), with World > Settings > Ray Visibility (export/visibility.py).
Textures and other nodes are approximated by the socket values."""

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
        if s.is_linked:
            warnings.add("linked input uses its own value (textures unsupported)", f"world '{world.name}': {s.name}")
    c = color.default_value
    return {"color": [c[0], c[1], c[2]], "strength": max(0.0, strength.default_value)}
