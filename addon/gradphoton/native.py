"""Finds and loads the compiled core, gradphoton._native, once.

Looked for, in order: the module next to this file (a copied install), the directory named by
the environment variable GRADPHOTON_NATIVE_PATH, and the build directory recorded in
native_path.txt by scripts/setup.sh (a linked install finds build/python next to addon/).
A missing or incompatible module never raises here: `error()` holds one readable message that
the engine reports in Blender instead of a traceback.
"""
import importlib
import importlib.util
import os
import sys

_module = None
_error = None


def _candidates():
    here = os.path.dirname(os.path.abspath(__file__))
    env = os.environ.get("GRADPHOTON_NATIVE_PATH")
    if env:
        yield env
    recorded = os.path.join(here, "native_path.txt")
    if os.path.isfile(recorded):
        with open(recorded, encoding="utf-8") as f:
            path = f.read().strip()
        if path:
            yield path
    # A linked install: <repo>/addon/gradphoton -> <repo>/build/python
    yield os.path.normpath(os.path.join(os.path.realpath(here), "..", "..", "build", "python"))


def load():
    """Returns the module or None (see error())."""
    global _module, _error
    if _module is not None:
        return _module
    errors = []
    try:  # copied install: _native*.so sits in this package
        _module = importlib.import_module(__package__ + "._native")
        _error = None
        return _module
    except ImportError as e:
        errors.append(f"bundled: {e}")
    for path in _candidates():
        if not os.path.isdir(os.path.join(path, "gradphoton")):
            errors.append(f"{path}: no gradphoton package")
            continue
        try:
            so = [f for f in os.listdir(os.path.join(path, "gradphoton")) if f.startswith("_native") and f.endswith(".so")]
            if not so:
                errors.append(f"{path}/gradphoton: no _native*.so (build it: scripts/setup.sh)")
                continue
            # Loaded as <this package>._native: the extension's init symbol is PyInit__native.
            name = __package__ + "._native"
            spec = importlib.util.spec_from_file_location(name, os.path.join(path, "gradphoton", so[0]))
            mod = importlib.util.module_from_spec(spec)
            spec.loader.exec_module(mod)
            sys.modules[name] = mod
            _module, _error = mod, None
            return _module
        except Exception as e:  # ImportError, undefined symbols, wrong Python ABI
            errors.append(f"{path}: {e}")
    _error = ("gradphoton: cannot load the native module gradphoton._native (Python "
              f"{sys.version_info.major}.{sys.version_info.minor}); run scripts/setup.sh. Tried: "
              + "; ".join(errors))
    print(_error, file=sys.stderr)
    return None


def get():
    """The module, or raises RuntimeError with the one readable message."""
    m = load()
    if m is None:
        raise RuntimeError(_error)
    return m


def error():
    return _error


def methods():
    m = load()
    return list(m.methods()) if m else []


def passes():
    """[(name, channels, label)] from the core's pass table (film.h pass::kAll)."""
    m = load()
    return [tuple(p) for p in m.passes()] if m else [("combined", 3, "Combined")]


_params = {}  # method -> its parameter declarations, asked once per session of Blender


def method_params(method):
    """The method's parameter declarations (_native.method_params: name, type, default, range,
    label, description, ...), [] without the module or for an unknown method."""
    m = load()
    if m is None:
        return []
    if method not in _params:
        try:
            _params[method] = [dict(d) for d in m.method_params(method)]
        except (ValueError, RuntimeError):
            _params[method] = []
    return _params[method]


_descriptions = {}  # method -> its description, asked once per session of Blender


def method_description(method):
    """The method as the core declares it (_native.method_description: label, tooltip, passes,
    error estimate, merge rule, statistics, supported features), or None without the module
    or for an unknown method."""
    m = load()
    if m is None:
        return None
    if method not in _descriptions:
        try:
            _descriptions[method] = dict(m.method_description(method))
        except (ValueError, RuntimeError):
            _descriptions[method] = None
    return _descriptions[method]


def method_label(method):
    """The method's readable name for menus (its own name without the module)."""
    d = method_description(method)
    return d["label"] if d else method


_info = {}  # (method, params) -> method_info, asked once per session of Blender


def method_info(method, params=None):
    """{'passes': [...], 'error_estimate': bool, 'unused': [...]} as the core's method declares
    it with `params` (_native.method_info), or None without the module or for an unknown method."""
    m = load()
    if m is None:
        return None
    params = dict(params or {})
    key = (method, tuple(sorted(params.items())))
    if key not in _info:
        try:
            _info[key] = dict(m.method_info(method, params))
        except (ValueError, RuntimeError, TypeError):  # unknown method, bad parameter
            _info[key] = None
    return _info[key]
