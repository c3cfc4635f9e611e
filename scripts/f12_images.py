"""When each image of an F12 render reached Blender, for scripts/bench_f12.py and
scripts/bench_f12_window.py: wraps the addon's RenderSession._write (the develop + copy into the
render result, which update_result follows at once) so that each call's end is marked.

    from f12_images import mark_images
    images = mark_images(session)        # a list: time.perf_counter() at the end of each image
    _write = mark_images(session, wrap)  # wrap(fn) -> fn: a timer of the caller's around _write
"""
import time


def mark_images(session, wrap=None):
    """Replaces session.RenderSession._write by one that appends perf_counter() to the returned
    list when each image has been written (`wrap`: applied to the original first)."""
    images = []
    write = session.RenderSession._write
    if wrap is not None:
        write = wrap(write)

    def write_and_mark(*a, **kw):
        try:
            return write(*a, **kw)
        finally:
            images.append(time.perf_counter())

    session.RenderSession._write = write_and_mark
    return images
