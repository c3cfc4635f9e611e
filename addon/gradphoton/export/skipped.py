"""What the core does not render, each counted once in the render's report instead of being
skipped without a word: hair (curves objects and hair particle systems) and liquid domains. A
material's or the World's Volume output is exported (export/volume.py), Volume objects too
(export/volume_object.py); a method that does not render media says so itself, naming it (the
session's feature_report). Motion blur is exported (export/motion.py); a method that does not
render it says so the same way."""


def check_object(ob, kind, warnings):
    if kind == 'CURVES':
        warnings.add("hair curves not rendered", ob.name)
    for md in getattr(ob, "modifiers", ()):
        if md.type == 'FLUID' and md.fluid_type == 'DOMAIN' and md.domain_settings.domain_type != 'GAS':
            warnings.add("fluid domain not rendered", ob.name)  # (smoke domains: export/fluid.py)
    for ps in getattr(ob, "particle_systems", ()):
        if ps.settings.type == 'HAIR' and ps.settings.render_type == 'PATH':
            warnings.add("hair curves not rendered", f"{ob.name}: {ps.name}")
