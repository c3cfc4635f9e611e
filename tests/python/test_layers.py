"""The integrators' rooms depend only downward (DESIGN.md "Shape"): shared pieces (paths/: the
spectral vocabulary and light chains; shift/: the shifts) below the method families (photon/,
spectral/, gradient/), the registry (methods.*) on top, the interface (integrator.h) below it.
A folder-level include cycle, or a shared room that includes a family, fails here."""
import pathlib
import re

ROOT = pathlib.Path(__file__).resolve().parents[2]
INTEGRATORS = ROOT / "native" / "integrators"
INCLUDE = re.compile(r'#include "integrators/([^"]+)"')
# Each room and the rooms it may include (besides itself and the top-level shared headers).
LAYERS = {
    "top": {"paths"},  # the interface and shared headers; path_tracer (pt) on the toolkit
    "paths": set(),
    "shift": {"paths"},
    "photon": {"paths"},
    "spectral": {"paths", "shift"},
    "gradient": {"paths", "shift", "photon"},  # GPM builds on SPPM
}
REGISTRY = {"methods.h", "methods.cpp"}


def room(rel):
    parts = rel.split("/")
    return parts[0] if len(parts) > 1 else "top"


def edges():
    out = []
    for path in INTEGRATORS.rglob("*.[ch]*"):
        rel = path.relative_to(INTEGRATORS).as_posix()
        for target in INCLUDE.findall(path.read_text()):
            out.append((rel, target))
    return out


def test_rooms_depend_only_downward():
    bad = []
    for src, dst in edges():
        a, b = room(src), room(dst)
        if a == b or b == "top":
            continue
        if a == "top" and src in REGISTRY:
            continue  # the registry sits on top of every family
        if b not in LAYERS.get(a, set()):
            bad.append(f"{src} includes {dst}")
    assert not bad, "\n".join(bad)


def test_no_folder_level_cycle():
    graph = {}
    for src, dst in edges():
        a, b = room(src), room(dst)
        if a != b and not (a == "top" and src in REGISTRY):
            graph.setdefault(a, set()).add(b)
    seen, stack = set(), []

    def visit(n):
        if n in stack:
            raise AssertionError("include cycle: " + " -> ".join(stack[stack.index(n):] + [n]))
        if n in seen:
            return
        stack.append(n)
        for m in graph.get(n, ()):
            visit(m)
        stack.pop()
        seen.add(n)

    for n in list(graph):
        visit(n)


def test_the_interface_does_not_include_the_registry():
    text = (INTEGRATORS / "integrator.h").read_text()
    assert '#include "integrators/methods.h"' not in text
