"""What the core does not render, each counted once in the render's report instead of being
skipped without a word: motion blur, hair (curves objects and hair particle systems) and
volumes (volume objects, a material's or the world's Volume output)."""


def check_object(ob, kind, warnings):
    if kind == 'CURVES':
        warnings.add("hair curves not rendered", ob.name)
    elif kind == 'VOLUME':
        warnings.add("volumes not rendered", ob.name)
    for ps in getattr(ob, "particle_systems", ()):
        if ps.settings.type == 'HAIR' and ps.settings.render_type == 'PATH':
            warnings.add("hair curves not rendered", f"{ob.name}: {ps.name}")


def _volume_linked(tree):
    return tree is not None and any(
        n.bl_idname in ('ShaderNodeOutputMaterial', 'ShaderNodeOutputWorld') and n.inputs.get("Volume") is not None
        and n.inputs["Volume"].is_linked for n in tree.nodes)


def check_scene(scene, materials, warnings):
    if scene.render.use_motion_blur:
        warnings.add("motion blur not rendered", scene.name)
    for mat in materials:
        if mat.use_nodes and _volume_linked(mat.node_tree):
            warnings.add("volumes not rendered", f"material '{mat.name}'")
    world = scene.world
    if world is not None and world.use_nodes and _volume_linked(world.node_tree):
        warnings.add("volumes not rendered", f"world '{world.name}'")
