"""The front ends agree with the methods' declarations (_native.method_params): the CLI's help
and `gradphoton methods`, the generated tables of docs/methods.md; the CLI's validation wording
and unused-parameter report. (Blender's properties and panels: tests/blender/test_method_params.py.)"""
import importlib.util
import pathlib
import re
import subprocess

import pytest
from gradphoton import _native as N

ROOT = pathlib.Path(__file__).resolve().parents[2]
CLI = ROOT / "build" / "gradphoton"
CORNELL = ROOT / "scenes" / "cornell-box.json"


def run(*args):
    return subprocess.run([str(CLI), *map(str, args)], capture_output=True, text=True, timeout=120)


def flag(name):
    return "--" + name.replace("_", "-")


def default_text(d):
    v = d["default"]
    text = ("true" if v else "false") if isinstance(v, bool) else v if isinstance(v, str) else f"{v:g}"
    return text + (f" ({d['zero_means']})" if d["zero_means"] and v == 0 else "")


def test_render_help_lists_every_parameter_with_each_methods_default():
    help_text = run("render", "--help").stdout
    options = {}
    for line in help_text.splitlines():  # "  --alpha FLOAT   fraction of ... Default 0.7 (ppm, ...); 0.6 (msppm)"
        m = re.match(r"\s+(--[a-z-]+) (INT|FLOAT|BOOL|TEXT)\s+(.*)", line)
        if m:
            options[m.group(1)] = m.group(3)
    for method in N.methods():
        for d in N.method_params(method):
            text = options.get(flag(d["name"]))
            assert text is not None, f"render --help has no {flag(d['name'])}"
            assert d["description"] in text, (d["name"], text)
            # this method's range (photons: >= 1 in ppm, >= 0 where 0 is automatic)
            assert not d["range"] or re.search(re.escape(d["range"]) + r"(\.| \(|;)", text), (method, d["name"], text)
            # this method's default, in the group of methods that share it
            groups = re.search(r"Default (.*)$", text).group(1)
            ok = any(g.startswith(default_text(d) + " (") and (method in re.split(r"[(), ]+", g) or "every method" in g)
                     for g in groups.split("; "))
            assert ok, (method, d["name"], groups)


@pytest.mark.parametrize("method", N.methods())
def test_methods_command_lists_the_declarations(method):
    out = run("methods", method).stdout
    rows = re.findall(r"^  (--[a-z-]+)\s+(int|float|bool|string)\s+default (\S+)", out, re.M)
    expected = [(flag(d["name"]), d["type"], "0" if d["zero_means"] else default_text(d))
                for d in N.method_params(method)]
    assert rows == expected


def test_docs_tables_are_the_declarations():
    """docs/methods.md's generated section is what scripts/method_params_doc.py makes now."""
    spec = importlib.util.spec_from_file_location("method_params_doc", ROOT / "scripts" / "method_params_doc.py")
    doc = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(doc)
    text = (ROOT / "docs" / "methods.md").read_text(encoding="utf-8")
    assert doc.updated(text, N) == text, "docs/methods.md differs from the declarations: run scripts/method_params_doc.py"
    for method in N.methods():
        assert f"### `{method}`" in text


def test_one_wording_and_the_unused_report_on_the_command_line(tmp_path):
    out = tmp_path / "x.exr"
    bad = run("render", CORNELL, "--method", "gpm", "--lambda", -1, "-o", out)
    assert bad.returncode == 1 and bad.stderr.strip() == "error: parameter 'lambda' of gpm must be > 0, got -1"
    # sgpt's Poisson weight is lambda (it read `alpha` while every front end sent `lambda`)
    p = run("render", ROOT / "scenes" / "prism.json", "--method", "sgpt", "--passes", 1, "--width", 8, "--height", 6,
            "--lambda", 0.5, "--alpha", 0.5, "--param", "bisn=3", "-o", out)
    assert p.returncode == 0, p.stderr
    warnings = [line for line in p.stderr.splitlines() if line.startswith("warning: parameter")]
    assert warnings == ["warning: parameter 'alpha' is not a parameter of sgpt",
                        "warning: parameter 'bisn' is not a parameter of sgpt (did you mean 'bins'?)"], p.stderr
    assert N.read_exr_metadata(str(out))["gradphoton.params"].count('"lambda":0.5') == 1
