"""The architecture as a test: invrad_wb's layers and its import graph.

Every import counts: module level and inside functions (that is where cycles hide),
``import a.b`` and ``from a import b`` (an edge to the module ``a.b`` when it is one, else
to ``a``), relative imports resolved against the importing module's package.

The rules (README, "Layout"):

* no cycle between modules of ``invrad_wb``;
* the core's subpackages form layers, each importing only those below it::

      model < accel < geometry < io < forward < output < inverse < design, synthetic

  model is the data (scene, luminaires, photometry, targets, the memory budget, the image
  reader its texture targets need); accel the OpenCL device and the kernel registry;
  geometry the BVH, rasters and meshes (it uploads to devices: above accel); io the file
  formats that build scenes (below every solver, which never reads files); forward the
  forward solve; output the metrics, images, figures and reports of a lit scene (no
  solver: inverse and design use it to show their results); inverse the locate pipeline;
  design the lighting design on top of locate and the reports; synthetic the generated
  test scenes, which nothing in the core imports;
* the core imports no FreeCAD, Qt, app, gui or cli; app imports no gui or cli;
* no module over :data:`MAX_LINES` lines, except those named in :data:`LONG_MODULES`
  (each must still be too long: a module that shrinks leaves the list).

The checker is tried on a small package of its own first, so that a new upward import, a
cycle or a long module is known to fail the test.
"""
import ast
import os
import textwrap

import pytest
from repo_paths import ROOT

PACKAGE = "invrad_wb"

#: the core's layers, lowest first; subpackages in one layer must not import each other
CORE_LAYERS = [("model",), ("accel",), ("geometry",), ("io",), ("forward",), ("output",),
               ("inverse",), ("design", "synthetic")]

#: app/'s modules in layers, lowest first: FreeCAD glue (and pip run as FreeCAD's Python);
#: a fixture's body; invrad's IFC data (ifcopenshell); the two document backends (classic
#: Arch, NativeIFC); the one interface that chooses between them per document; rooms (and
#: the dependency checks); targets and fixtures on them, what the building says about a
#: room's ceiling (roomzones); IFC import/export and the design
#: specs; the pipeline; results (verify, re-insert, sheets)
APP_LAYERS = [("settings", "units", "document", "pip_runner"), ("fixturebody",), ("ifcdata",),
              ("nativeifc", "classic"), ("backend", "aimsync"), ("rooms", "dependencies"),
              ("targets", "fixtures", "roomzones"), ("ifcrooms", "ifcexport", "design"),
              ("ifcimport", "pipeline"), ("results",)]

#: top-level modules of FreeCAD and Qt (the core runs without them)
FREECAD_MODULES = {"FreeCAD", "FreeCADGui", "Part", "Mesh", "MeshPart", "Arch", "ArchIFC",
                   "Draft", "DraftGeomUtils", "nativeifc", "BOPTools", "PySide", "PySide2",
                   "PySide6", "shiboken2", "shiboken6", "pivy"}

MAX_LINES = 800
#: modules allowed over MAX_LINES for now, with the reason; the test fails once one is short
LONG_MODULES = {}

# --------------------------------------------------------------------------- the checker
def find_modules(root, package):
    """{dotted module name: file path} of every .py file of ``package`` under ``root``
    (a package's ``__init__.py`` is the package itself)."""
    out = {}
    for folder, dirs, files in os.walk(os.path.join(root, package)):
        dirs[:] = sorted(d for d in dirs if d != "__pycache__" and not d.startswith("."))
        for f in sorted(files):
            if f.endswith(".py"):
                path = os.path.join(folder, f)
                parts = os.path.relpath(path, root)[:-3].split(os.sep)
                if parts[-1] == "__init__":
                    parts = parts[:-1]
                out[".".join(parts)] = path
    return out


def imported_names(name, path):
    """Every import of the module ``name`` (file ``path``), anywhere in it:
    [(dotted module, imported name or None, line)]; ``import a.b`` gives ``("a.b", None)``,
    ``from a import b`` ``("a", "b")`` (b a module or a name in a)."""
    with open(path, "r", encoding="utf-8") as fh:
        tree = ast.parse(fh.read(), path)
    package = name if path.endswith("__init__.py") else name.rpartition(".")[0]
    out = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            out.extend((a.name, None, node.lineno) for a in node.names)
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")
                base = base[:len(base) - (node.level - 1)]
                mod = ".".join(base + ([node.module] if node.module else []))
            else:
                mod = node.module or ""
            out.extend((mod, a.name, node.lineno) for a in node.names)
    return out


def import_graph(root, package):
    """({module: {imported module of the package: first line}}, {module: external top-level
    names it imports}). An import of ``a.b.c`` where only ``a.b`` is a module counts as
    ``a.b`` (``from a.b import c``, c a name)."""
    modules = find_modules(root, package)
    graph, external = {}, {}
    for name, path in modules.items():
        edges, ext = {}, set()
        for dotted, what, line in imported_names(name, path):
            top = dotted.split(".")[0]
            if top != package:
                if top:
                    ext.add(top)
                continue
            if what is not None and f"{dotted}.{what}" in modules:
                dotted = f"{dotted}.{what}"          # from a import b, b a module
            parts = dotted.split(".")
            while parts and ".".join(parts) not in modules:
                parts.pop()
            target = ".".join(parts)
            if target and target != name:
                edges.setdefault(target, line)
        graph[name] = edges
        external[name] = ext
    return graph, external


def cycles(graph):
    """The strongly connected components with more than one node, each sorted (Tarjan)."""
    index, low, stack, on, out = {}, {}, [], set(), []
    counter = [0]

    def visit(v):
        work = [(v, iter(sorted(graph.get(v, ()))))]
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        while work:
            node, it = work[-1]
            advanced = False
            for w in it:
                if w not in index:
                    index[w] = low[w] = counter[0]
                    counter[0] += 1
                    stack.append(w)
                    on.add(w)
                    work.append((w, iter(sorted(graph.get(w, ())))))
                    advanced = True
                    break
                if w in on:
                    low[node] = min(low[node], index[w])
            if advanced:
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[node])
            if low[node] == index[node]:
                comp = []
                while True:
                    w = stack.pop()
                    on.discard(w)
                    comp.append(w)
                    if w == node:
                        break
                if len(comp) > 1:
                    out.append(sorted(comp))
    for v in sorted(graph):
        if v not in index:
            visit(v)
    return sorted(out)


def subpackage_of(module, package, area="core"):
    """X for a module ``package.area.X`` or ``package.area.X.*`` (core: its subpackage,
    app: its module), else None."""
    parts = module.split(".")
    if len(parts) >= 3 and parts[0] == package and parts[1] == area:
        return parts[2]
    return None


def layer_violations(graph, package, layers, area="core"):
    """Imports between the parts of ``package.area`` that do not go down the layers:
    ['a.b (x, layer i) imports c.d (y, layer j) at line n: not below it']."""
    rank = {sub: i for i, layer in enumerate(layers) for sub in layer}
    out = []
    for mod, edges in sorted(graph.items()):
        a = subpackage_of(mod, package, area)
        if a is None:
            continue
        for target, line in sorted(edges.items()):
            b = subpackage_of(target, package, area)
            if b is None or b == a:
                continue
            if a not in rank or b not in rank:
                out.append(f"{mod} imports {target} (line {line}): subpackage"
                           f" {a if a not in rank else b} has no layer")
            elif rank[b] >= rank[a]:
                out.append(f"{mod} ({a}, layer {rank[a]}) imports {target} ({b}, layer"
                           f" {rank[b]}) at line {line}: not below it")
    return out


def forbidden_imports(graph, external, package):
    """Imports across the outer layers: the core of FreeCAD/Qt/app/gui/cli, app of gui/cli."""
    out = []
    for mod in sorted(graph):
        parts = mod.split(".")
        area = parts[1] if len(parts) > 1 else None
        if area == "core":
            banned_internal = ("app", "gui", "cli")
            bad_ext = sorted(external[mod] & FREECAD_MODULES)
            out.extend(f"{mod} imports {e} (FreeCAD/Qt)" for e in bad_ext)
        elif area == "app":
            banned_internal = ("gui", "cli")
        else:
            continue
        for target, line in sorted(graph[mod].items()):
            t = target.split(".")
            if len(t) > 1 and t[1] in banned_internal:
                out.append(f"{mod} imports {target} at line {line}")
    return out


def long_modules(root, package, max_lines):
    """{path relative to root: lines} of the modules over ``max_lines``."""
    out = {}
    for path in find_modules(root, package).values():
        with open(path, "r", encoding="utf-8") as fh:
            n = sum(1 for _ in fh)
        if n > max_lines:
            out[os.path.relpath(path, root).replace(os.sep, "/")] = n
    return out


# --------------------------------------------------------------------------- invrad_wb
@pytest.fixture(scope="module")
def graph():
    return import_graph(ROOT, PACKAGE)


def test_the_graph_sees_imports_inside_functions_and_relative_ones(graph):
    g, _ = graph
    # cli.locate imports the locate pipeline inside a function only
    assert "invrad_wb.core.inverse.locate" in g["invrad_wb.cli.locate"]
    assert "invrad_wb.cli.common" in g["invrad_wb.cli.locate"]
    assert len(g) > 100


def test_no_import_cycle_between_modules(graph):
    found = cycles(graph[0])
    assert found == [], (
        "import cycles (every import counts, inside functions too):\n"
        + "\n".join(" -> ".join(c) for c in found))


def test_core_subpackages_import_only_lower_layers(graph):
    g, _ = graph
    subs = {subpackage_of(m, PACKAGE) for m in g} - {None}
    layered = {s for layer in CORE_LAYERS for s in layer}
    assert subs == layered, f"core subpackages without a layer: {sorted(subs - layered)}"
    assert layer_violations(g, PACKAGE, CORE_LAYERS) == []
    between = {}
    for mod, edges in g.items():
        a = subpackage_of(mod, PACKAGE)
        for target in edges:
            b = subpackage_of(target, PACKAGE)
            if a and b and a != b:
                between.setdefault(a, {})[b] = 1
    assert cycles(between) == []


def test_app_modules_import_only_lower_layers(graph):
    g, _ = graph
    mods = {subpackage_of(m, PACKAGE, "app") for m in g} - {None}
    layered = {s for layer in APP_LAYERS for s in layer}
    assert mods == layered, f"app modules without a layer: {sorted(mods - layered)}"
    assert layer_violations(g, PACKAGE, APP_LAYERS, area="app") == []


def test_core_and_app_stay_below_the_front_ends(graph):
    assert forbidden_imports(*graph, PACKAGE) == []


def test_no_module_over_the_line_limit():
    found = long_modules(ROOT, PACKAGE, MAX_LINES)
    extra = {p: n for p, n in found.items() if p not in LONG_MODULES}
    assert extra == {}, f"modules over {MAX_LINES} lines: {extra}"
    shrunk = sorted(set(LONG_MODULES) - set(found))
    assert shrunk == [], f"now at most {MAX_LINES} lines: remove from LONG_MODULES: {shrunk}"


def kernel_launchers(root, package):
    """{kernel program name: [modules launching it]}: the ``env.kernel("name", ...)`` calls
    of the package (a string literal first argument)."""
    out = {}
    for name, path in find_modules(root, package).items():
        with open(path, "r", encoding="utf-8") as fh:
            tree = ast.parse(fh.read(), path)
        for node in ast.walk(tree):
            if (isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute)
                    and node.func.attr == "kernel" and node.args
                    and isinstance(node.args[0], ast.Constant)
                    and isinstance(node.args[0].value, str)):
                out.setdefault(node.args[0].value, set()).add(name)
    return {k: sorted(v) for k, v in out.items()}


def test_each_kernel_family_lives_in_one_module():
    """Each kernels/*.cl is launched from one core module, which registers its numpy twin
    (accel.registry finds it by its register() call: no list kept by hand)."""
    from invrad_wb.core.accel.registry import kernel_modules, pairs
    sources = sorted(f[:-3] for f in os.listdir(os.path.join(ROOT, "kernels"))
                     if f.endswith(".cl"))
    launchers = kernel_launchers(ROOT, PACKAGE)
    assert sorted(launchers) == sources
    for program, mods in launchers.items():
        assert len(mods) == 1 and mods[0].startswith("invrad_wb.core."), (program, mods)
        assert mods[0] in kernel_modules(), f"{mods[0]} launches {program}.cl: no twin"
    assert len(pairs()) >= len(sources)


# --------------------------------------------------------------------------- the checker
def _package(tmp_path, files):
    for rel, text in files.items():
        path = tmp_path / rel
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(textwrap.dedent(text))
    return str(tmp_path)


GOOD = {
    "pkg/__init__.py": "",
    "pkg/core/__init__.py": "",
    "pkg/core/model/__init__.py": "",
    "pkg/core/model/scene.py": "import numpy as np\n",
    "pkg/core/io/__init__.py": "",
    "pkg/core/io/ply.py": "from ..model import scene\nfrom pkg.core.model.scene import x\n",
    "pkg/core/forward/__init__.py": "",
    "pkg/core/forward/render.py": "def f():\n    from pkg.core.io import ply\n",
    "pkg/app/__init__.py": "",
    "pkg/app/rooms.py": "import FreeCAD\nfrom pkg.core.forward.render import f\n",
    "pkg/gui/__init__.py": "",
    "pkg/gui/panel.py": "from pkg.app import rooms\n",
}
LAYERS = [("model",), ("io",), ("forward",)]


def test_the_checker_passes_a_layered_package(tmp_path):
    root = _package(tmp_path, GOOD)
    g, ext = import_graph(root, "pkg")
    assert g["pkg.core.io.ply"] == {"pkg.core.model.scene": 1}
    assert g["pkg.core.forward.render"] == {"pkg.core.io.ply": 2}
    assert cycles(g) == []
    assert layer_violations(g, "pkg", LAYERS) == []
    assert forbidden_imports(g, ext, "pkg") == []


def test_the_checker_fails_on_an_upward_import_inside_a_function(tmp_path):
    files = dict(GOOD)
    files["pkg/core/model/scene.py"] = """\
        import numpy as np


        def load(path):
            from ..io.ply import read      # the model reaching up for a reader
            return read(path)
        """
    g, ext = import_graph(_package(tmp_path, files), "pkg")
    assert cycles(g) == [["pkg.core.io.ply", "pkg.core.model.scene"]]
    bad = layer_violations(g, "pkg", LAYERS)
    assert len(bad) == 1 and "pkg.core.model.scene (model, layer 0) imports pkg.core.io.ply" \
        in bad[0] and "line 5" in bad[0]


def test_the_checker_fails_on_a_skipped_layer_rule_and_front_end_imports(tmp_path):
    files = dict(GOOD)
    files["pkg/core/io/ply.py"] = "from pkg.core.forward.render import f\n"   # no cycle
    files["pkg/core/forward/render.py"] = "import FreeCAD\nimport PySide.QtGui\n"
    files["pkg/app/rooms.py"] = "def f():\n    import pkg.gui.panel\n"
    files["pkg/core/extra/__init__.py"] = ""
    g, ext = import_graph(_package(tmp_path, files), "pkg")
    assert layer_violations(g, "pkg", LAYERS) == [
        "pkg.core.io.ply (io, layer 1) imports pkg.core.forward.render (forward, layer 2) at"
        " line 1: not below it"]
    assert forbidden_imports(g, ext, "pkg") == [
        "pkg.app.rooms imports pkg.gui.panel at line 2",
        "pkg.core.forward.render imports FreeCAD (FreeCAD/Qt)",
        "pkg.core.forward.render imports PySide (FreeCAD/Qt)"]
    assert cycles(g) == [["pkg.app.rooms", "pkg.gui.panel"]]


def test_the_checker_counts_lines(tmp_path):
    root = _package(tmp_path, {"pkg/__init__.py": "", "pkg/big.py": "x = 1\n" * 12,
                               "pkg/small.py": "x = 1\n" * 10})
    assert long_modules(root, "pkg", 10) == {"pkg/big.py": 12}
