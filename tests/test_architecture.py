"""The package's layers import one way: read from every module's source (``ast``), nothing is imported.

Layers, lowest first (a module may import its own layer or lower ones, never a higher one):

0 base        errors, version, channels, kernels, components, registry, buffers, compiled (package), compiled.mj,
              compiled.numpy_order, compiled.views, compiled.lanes, limits, strict, safeyaml, outdir, lifecycle, numba_cache,
              free_parameters
1 components  vehicles, effects, actuators, roads, sensors, controllers, maneuvers, maneuvers_dlc
2 config      config
3 build       plant, build (scenario -> a System of components; no stepping)
4 run         loop (the Python loop), divergence, compiled.loop, compiled.testing
5 log         log
6 metrics     metrics, results, stream
7 outputs     outputs, plots, plots_frequency, report, viewer
8 simulation  simulation (build + run + log)
9 apps        the package root, batch, envs, rl, preflight, cli, commands, diagnose, reproductions

Also: no import cycles (imports inside functions count), no ``from x import _private`` from another module,
and a private module (``_common.py``) is imported only from inside its own package.  A new module must be
placed in :data:`MODULES` or under one of :data:`PACKAGES` (a new effect, road, metric ... file is placed by
its package).  The checker runs on a small synthetic package too, to show that each rule can fail.
"""
from __future__ import annotations

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
# import name -> folder (pyproject.toml maps controllers/ into the package)
SOURCES = {"suspension_sim": ROOT / "suspension_sim", "suspension_sim.controllers": ROOT / "controllers"}

BASE, COMPONENTS, CONFIG, BUILD, RUN, LOG, METRICS, OUTPUTS, SIMULATION, APPS = range(10)
# exact module names
MODULES = {
    "suspension_sim": APPS,
    "suspension_sim.errors": BASE, "suspension_sim.version": BASE, "suspension_sim.channels": BASE,
    "suspension_sim.limits": BASE, "suspension_sim.strict": BASE, "suspension_sim.safeyaml": BASE,
    "suspension_sim.outdir": BASE, "suspension_sim.lifecycle": BASE, "suspension_sim.numba_cache": BASE, "suspension_sim.free_parameters": BASE,
    "suspension_sim.kernels": BASE, "suspension_sim.components": BASE, "suspension_sim.registry": BASE,
    "suspension_sim.compiled": BASE, "suspension_sim.compiled.mj": BASE, "suspension_sim.compiled.numpy_order": BASE,
    "suspension_sim.compiled.views": BASE, "suspension_sim.compiled.lanes": BASE, "suspension_sim.buffers": BASE,
    "suspension_sim.maneuvers": COMPONENTS, "suspension_sim.maneuvers_dlc": COMPONENTS,
    "suspension_sim.config": CONFIG,
    "suspension_sim.plant": BUILD, "suspension_sim.build": BUILD, "suspension_sim.statics": BUILD,
    "suspension_sim.loop": RUN, "suspension_sim.divergence": RUN, "suspension_sim.compiled.loop": RUN, "suspension_sim.compiled.testing": RUN,
    "suspension_sim.log": LOG,
    "suspension_sim.results": METRICS, "suspension_sim.stream": METRICS,
    "suspension_sim.outputs": OUTPUTS, "suspension_sim.plots": OUTPUTS, "suspension_sim.plots_frequency": OUTPUTS,
    "suspension_sim.report": OUTPUTS,
    "suspension_sim.simulation": SIMULATION,
    "suspension_sim.batch": APPS, "suspension_sim.envs": APPS, "suspension_sim.cli": APPS,
    "suspension_sim.preflight": APPS,
}
# a package and every module in it
PACKAGES = {
    "suspension_sim.vehicles": COMPONENTS, "suspension_sim.effects": COMPONENTS,
    "suspension_sim.actuators": COMPONENTS, "suspension_sim.roads": COMPONENTS,
    "suspension_sim.sensors": COMPONENTS, "suspension_sim.controllers": COMPONENTS,
    "suspension_sim.metrics": METRICS,
    "suspension_sim.viewer": OUTPUTS,
    "suspension_sim.commands": APPS, "suspension_sim.diagnose": APPS, "suspension_sim.reproductions": APPS,
    "suspension_sim.rl": APPS,
}
KNOWN_CYCLES: list = []  # import cycles still to cut (sorted module lists): none
LAYER_NAMES = ["base", "components", "config", "build", "run", "log", "metrics", "outputs", "simulation", "apps"]


def discover(sources: dict) -> dict:
    """module name -> (path, is_package) of every .py file under the source folders."""
    out = {}
    for pkg, folder in sources.items():
        for path in sorted(folder.rglob("*.py")):
            parts = list(path.relative_to(folder).with_suffix("").parts)
            if any(p.startswith(".") or p == "__pycache__" for p in parts):
                continue
            is_pkg = parts[-1] == "__init__"
            if is_pkg:
                parts = parts[:-1]
            out[".".join([pkg] + parts)] = (path, is_pkg)
    return out


def imports(name: str, path: Path, is_pkg: bool, modules: dict, top: str) -> list:
    """(imported module, imported names or None, line) of every import of the package ``top`` in a module,
    top-level or inside functions.  ``from pkg import sub`` counts as an import of the module ``pkg.sub``."""
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    here = name if is_pkg else name.rpartition(".")[0]
    out = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for a in node.names:
                if a.name == top or a.name.startswith(top + "."):
                    out.append((a.name, None, node.lineno))
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = here.split(".")
                base = base[:len(base) - (node.level - 1)]
                target = ".".join(base + ([node.module] if node.module else []))
            else:
                target = node.module or ""
            if not (target == top or target.startswith(top + ".")):
                continue
            names = []
            for a in node.names:
                sub = f"{target}.{a.name}"
                if sub in modules:  # a submodule, imported by name
                    out.append((sub, None, node.lineno))
                else:
                    names.append(a.name)
            if names:
                out.append((target, names, node.lineno))
    return out


def layer_of(name: str, modules_map: dict, packages_map: dict):
    if name in modules_map:
        return modules_map[name]
    best = None
    for pkg, layer in packages_map.items():
        if (name == pkg or name.startswith(pkg + ".")) and (best is None or len(pkg) > len(best[0])):
            best = (pkg, layer)
    return best[1] if best else None


def resolve(target: str, modules: dict):
    """The module an import refers to (``a.b.c`` may name an object c of module a.b)."""
    while target and target not in modules:
        target = target.rpartition(".")[0]
    return target or None


def is_private(name: str) -> bool:
    return name.startswith("_") and not (name.startswith("__") and name.endswith("__"))


def find_cycles(graph: dict) -> list:
    """Strongly connected components with more than one module (or a module importing itself)."""
    index, low, stack, on, out, counter = {}, {}, [], set(), [], [0]

    def visit(v):  # Tarjan, iterative enough for a package of this size
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in sorted(graph.get(v, ())):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1 or v in graph.get(v, ()):
                out.append(sorted(comp))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return out


def check(sources: dict, modules_map: dict, packages_map: dict, top: str, known_cycles=()) -> list[str]:
    """Every breach of the rules, one line each."""
    modules = discover(sources)
    problems = []
    graph: dict = {m: set() for m in modules}
    for name, (path, is_pkg) in modules.items():
        layer = layer_of(name, modules_map, packages_map)
        if layer is None:
            problems.append(f"{name}: no layer (add it to MODULES in tests/test_architecture.py)")
            continue
        for target, names, line in imports(name, path, is_pkg, modules, top):
            mod = resolve(target, modules)
            if mod is None:
                problems.append(f"{name}:{line}: imports {target}, which is not a module of the package")
                continue
            if mod != name:
                graph[name].add(mod)
            tl = layer_of(mod, modules_map, packages_map)
            if tl is not None and tl > layer:
                problems.append(f"{name}:{line}: layer {LAYER_NAMES[layer]} imports {mod} of the higher layer "
                                f"{LAYER_NAMES[tl]}")
            priv = [n for n in (names or []) if is_private(n)]
            if priv and mod != name:
                problems.append(f"{name}:{line}: imports private {priv} from {mod}")
            leaf = mod.rpartition(".")[2]
            parent = mod.rpartition(".")[0]
            inside = name == parent or name.startswith(parent + ".")
            if is_private(leaf) and not inside:
                problems.append(f"{name}:{line}: imports the private module {mod} from outside its package")
    for comp in find_cycles(graph):
        if comp in known_cycles:
            continue
        problems.append("import cycle: " + " <-> ".join(comp))
    return problems


def test_the_package_imports_one_way():
    problems = check(SOURCES, MODULES, PACKAGES, "suspension_sim", KNOWN_CYCLES)
    assert not problems, "\n".join(problems)


def test_every_layer_is_used_and_the_sources_are_found():
    modules = discover(SOURCES)
    assert "suspension_sim.controllers.skyhook" in modules and "suspension_sim.effects.bump_stop" in modules
    used = {layer_of(m, MODULES, PACKAGES) for m in modules}
    assert used == set(range(len(LAYER_NAMES)))
    assert all(m in modules for m in MODULES), [m for m in MODULES if m not in modules]


def _write(root: Path, files: dict) -> None:
    for rel, text in files.items():
        p = root / rel
        p.parent.mkdir(parents=True, exist_ok=True)
        p.write_text(text)


def test_the_checker_finds_each_kind_of_breach(tmp_path):
    """A synthetic package: low (layer 0), high (1), comps/ (1, with a private helper module), outsider (1)."""
    layers = {"pkg": 1, "pkg.low": 0, "pkg.high": 1, "pkg.outsider": 1, "pkg.a": 1, "pkg.b": 1}
    packages = {"pkg.comps": 1}
    clean = {
        "pkg/__init__.py": "",
        "pkg/low.py": "X = 1\n_hidden = 2\n",
        "pkg/high.py": "from .low import X\nfrom pkg import low\n",
        "pkg/comps/__init__.py": "",
        "pkg/comps/_common.py": "def helper():\n    return 1\n",
        "pkg/comps/one.py": "from ._common import helper\n",
        "pkg/outsider.py": "from .high import low\n",
        "pkg/a.py": "from . import low\n",
        "pkg/b.py": "def f():\n    from .a import low\n",
    }
    _write(tmp_path, clean)
    assert check({"pkg": tmp_path / "pkg"}, layers, packages, "pkg") == []

    # an upward import, hidden inside a function
    _write(tmp_path, {"pkg/low.py": "X = 1\n_hidden = 2\n\ndef f():\n    from .high import X\n"})
    found = check({"pkg": tmp_path / "pkg"}, layers, packages, "pkg")
    assert any("pkg.low:5: layer base imports pkg.high" in p for p in found), found
    assert any(p.startswith("import cycle: pkg.high <-> pkg.low") for p in found), found
    _write(tmp_path, {"pkg/low.py": clean["pkg/low.py"]})

    # a cycle within one layer
    _write(tmp_path, {"pkg/a.py": "from . import low\nfrom .b import f\n"})
    found = check({"pkg": tmp_path / "pkg"}, layers, packages, "pkg")
    assert found == ["import cycle: pkg.a <-> pkg.b"], found
    _write(tmp_path, {"pkg/a.py": clean["pkg/a.py"]})

    # a private name, and a private module from outside its package
    _write(tmp_path, {"pkg/outsider.py": "from .low import _hidden\nfrom .comps._common import helper\n"})
    found = check({"pkg": tmp_path / "pkg"}, layers, packages, "pkg")
    assert any("imports private ['_hidden'] from pkg.low" in p for p in found), found
    assert any("imports the private module pkg.comps._common from outside its package" in p for p in found), found
    _write(tmp_path, {"pkg/outsider.py": clean["pkg/outsider.py"]})

    # a new module nobody placed
    _write(tmp_path, {"pkg/newcomer.py": "X = 3\n"})
    found = check({"pkg": tmp_path / "pkg"}, layers, packages, "pkg")
    assert found == ["pkg.newcomer: no layer (add it to MODULES in tests/test_architecture.py)"], found
