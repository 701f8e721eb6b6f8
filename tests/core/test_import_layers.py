"""The layers point only down: bpy-free core (``illumap``) → pure pipeline → Blender layer.

The imports of every module of core/python/illumap and addon are read with ``ast`` (module-level
and function-level alike: a lazy import closes a cycle as surely as an eager one) and checked:

* no import cycle among them;
* ``illumap`` imports neither ``bpy`` nor the add-on;
* the add-on's pure modules import no ``bpy``, and not the core at module level;
* what registers without the native core (the reduced UI) imports, at module level, directly
  or through another add-on module, no ``illumap`` module but the pure ones (``PURE_CORE``:
  the settings and their limits), which import nothing native themselves; a guarded import
  of the add-on's own modules is refused, since it hides a broken layer (the presets were once
  read that way from the pipeline and were silently empty without the core).

Imports under ``if TYPE_CHECKING:`` count for cycles (an annotation that needs a module above
it is a layer upside down) and nowhere else.
"""

import ast
import os

import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
PACKAGES = {"illumap": os.path.join(ROOT, "core", "python", "illumap"),
            "addon": os.path.join(ROOT, "addon")}
#: Add-on modules that are pure: numpy and the core in, numpy out, no Blender.
PURE_ADDON = ("addon.kinds", "addon.core_status", "addon.errors", "addon.compute_task",
              "addon.job")
#: The core modules that import without the native module (pure Python, no numpy): the reduced
#: UI declares its settings from them.
PURE_CORE = ("illumap", "illumap.settings", "illumap.limits")
#: Native extension modules (built, not in the tree).
NATIVE = ("illumap._core",)
#: What the add-on registers when the native core does not import.
REDUCED_UI = ("addon", "addon.ui.properties", "addon.ui.preferences", "addon.ui.panel",
              "addon.preview.surfel_preview", "addon.ui.operators", "addon.ui.tool_operators")


def _modules():
    """Module name → (path, is_package) for every .py file of the packages."""
    out = {}
    for package, folder in PACKAGES.items():
        for dirpath, _dirs, files in os.walk(folder):
            rel = os.path.relpath(dirpath, folder)
            parts = [package] + ([] if rel == "." else rel.split(os.sep))
            for f in files:
                if not f.endswith(".py"):
                    continue
                if f == "__init__.py":
                    out[".".join(parts)] = (os.path.join(dirpath, f), True)
                else:
                    out[".".join(parts + [f[:-3]])] = (os.path.join(dirpath, f), False)
    return out


MODULES = _modules()


def _imports(name, with_typing=False):
    """(imported module name, when) for each import of module ``name``, ``when`` True at module
    level, "guarded" at module level inside a ``try``, False inside a function: the module a
    ``from X import y`` reads is X.y when that is a module, else X."""
    path, is_package = MODULES[name]
    with open(path, encoding="utf-8") as f:
        tree = ast.parse(f.read(), path)
    package = name if is_package else name.rpartition(".")[0]
    typing_only = {id(n) for node in ast.walk(tree) if isinstance(node, ast.If)
                   and "TYPE_CHECKING" in ast.unparse(node.test) for n in ast.walk(node)}
    typing_only = set() if with_typing else typing_only
    guarded = {id(n) for top in tree.body if isinstance(top, ast.Try) for n in ast.walk(top)}
    conditional = {id(n) for top in tree.body if isinstance(top, ast.If) for n in ast.walk(top)}
    top_level = {id(node) for node in tree.body}
    for node in ast.walk(tree):
        if id(node) in typing_only:
            continue
        if id(node) in guarded:
            eager = "guarded"
        else:
            eager = id(node) in top_level or id(node) in conditional
        if isinstance(node, ast.Import):
            for alias in node.names:
                yield alias.name, eager
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")
                base = base[:len(base) - (node.level - 1)]
                source = ".".join(base + ([node.module] if node.module else []))
            else:
                source = node.module
            for alias in node.names:
                sub = f"{source}.{alias.name}"
                yield (sub if sub in MODULES or sub in NATIVE else source), eager


GRAPH = {name: sorted({m for m, _ in _imports(name, with_typing=True) if m in MODULES})
         for name in MODULES}
EAGER = {name: sorted({m for m, when in _imports(name) if when is True}) for name in MODULES}
GUARDED = {name: sorted({m for m, when in _imports(name) if when == "guarded"})
           for name in MODULES}


def _cycles(graph):
    """Every cycle found by a depth-first search, as a list of module names."""
    found, state, stack = [], {}, []

    def visit(node):
        state[node] = "open"
        stack.append(node)
        for nxt in graph.get(node, ()):
            if state.get(nxt) == "open":
                found.append(stack[stack.index(nxt):] + [nxt])
            elif nxt not in state:
                visit(nxt)
        stack.pop()
        state[node] = "done"
    for node in sorted(graph):
        if node not in state:
            visit(node)
    return found


def test_the_tree_was_read():
    assert {"illumap", "illumap.solver", "illumap.api", "illumap.accuracy.choice",
            "addon", "addon.pipeline", "addon.ui.properties"} <= set(MODULES)
    assert "illumap.solver" in GRAPH["illumap.accuracy.automatic"]


def test_no_import_cycles():
    assert _cycles(GRAPH) == []


@pytest.mark.parametrize("name", PURE_CORE)
def test_the_pure_core_needs_nothing_native(name):
    """What the reduced UI reads of the core imports neither numpy nor the native module, at
    module level, nor any core module but the pure ones."""
    for mod in EAGER[name] + GUARDED[name]:
        assert mod.split(".")[0] not in ("numpy", "bpy") and mod not in NATIVE, (name, mod)
        assert mod.split(".")[0] != "illumap" or mod in PURE_CORE, (name, mod)


def test_an_annotation_import_closes_a_cycle(tmp_path, monkeypatch):
    """Imports under TYPE_CHECKING are read for cycles: one back up is found."""
    (tmp_path / "low.py").write_text("from typing import TYPE_CHECKING\n"
                                     "if TYPE_CHECKING:\n    from addon.high import Thing\n")
    (tmp_path / "high.py").write_text("from addon import low\n")
    monkeypatch.setitem(MODULES, "addon.low", (str(tmp_path / "low.py"), False))
    monkeypatch.setitem(MODULES, "addon.high", (str(tmp_path / "high.py"), False))
    graph = {name: sorted({m for m, _ in _imports(name, with_typing=True) if m in MODULES})
             for name in ("addon.low", "addon.high")}
    assert _cycles(graph) == [["addon.high", "addon.low", "addon.high"]]
    assert "addon.high" not in EAGER.get("addon.low", ())


def test_the_check_finds_a_cycle():
    """A lazy import back up (as solver once imported the automatic mode) is a cycle."""
    graph = dict(GRAPH, **{"illumap.solver": GRAPH["illumap.solver"] + ["illumap.accuracy"]})
    assert _cycles(graph)


@pytest.mark.parametrize("name", sorted(m for m in MODULES if m.startswith("illumap")))
def test_the_core_imports_neither_bpy_nor_the_addon(name):
    bad = [m for m, _ in _imports(name) if m.split(".")[0] in ("bpy", "addon")]
    assert bad == [], f"{name} imports {bad}"


@pytest.mark.parametrize("name", PURE_ADDON)
def test_pure_addon_modules_need_neither_blender_nor_the_core(name):
    assert not [m for m, _ in _imports(name) if m.split(".")[0] == "bpy"]
    assert not [m for m in EAGER[name] + GUARDED[name]
                if m.split(".")[0] == "illumap" and m not in PURE_CORE]


@pytest.mark.parametrize("name", REDUCED_UI)
def test_the_reduced_ui_imports_without_the_core(name):
    """Module-level imports, followed through the add-on's own modules, reach no ``illumap``
    (so e.g. the presets table is there without the core); none of them guards an import of
    the add-on's own code."""
    seen, todo = set(), [name]
    while todo:
        mod = todo.pop()
        if mod in seen:
            continue
        seen.add(mod)
        assert mod.split(".")[0] != "illumap" or mod in PURE_CORE, \
            f"{name} imports {mod} at module level"
        hidden = [m for m in GUARDED.get(mod, ()) if m.split(".")[0] == "addon"]
        assert not hidden, f"{mod} imports {hidden} inside a try"
        todo += [m for m in EAGER.get(mod, ()) if m in MODULES or m.split(".")[0] == "illumap"]
