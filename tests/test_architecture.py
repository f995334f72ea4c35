"""Dependencies point one way: core <- solver <- {blender_addon, manipulation} <- phyrogen (the command line).

Every module's imports are read from its source (function-level imports
too), so a lazy import that points up a layer fails here as well.
"""

from __future__ import annotations

import ast
import sys
from pathlib import Path

REPOSITORY = Path(__file__).resolve().parent.parent

LAYERS = {"phyrogen_core": 1, "solver": 2, "blender_addon": 3, "manipulation": 3, "phyrogen": 4}
"""A package may import packages of a lower layer, and itself; never a higher one or a sibling."""

THIRD_PARTY = {
    "phyrogen_core": {"numpy"},
    "solver": {"numpy", "ompl", "numba", "tqdm", "matplotlib", "ray", "pyarrow", "duckdb"},
    "blender_addon": {"numpy", "bpy", "mathutils", "addon_utils", "bpy_extras",
                      "PIL",  # Pillow writes the solution animation (animated WebP) from Blender's frames
                      "phobos"},  # the Phobos add-on, imported only by Export with Phobos while it is enabled
    "manipulation": {"numpy", "numba", "pybullet", "pybullet_data", "imageio", "tqdm", "ompl"},
    "phyrogen": {"tqdm", "numpy", "gymnasium"},
}
"""Outside the standard library, what each package may import."""

OMPL_USERS_ABOVE_SOLVER = {"manipulation.reaching": "plans the arm's reaching motions with OMPL's BIT*"}
"""Modules above the solver that use OMPL themselves (not just to read or densify a path)."""


def module_imports(root: Path, packages=tuple(LAYERS)) -> dict[str, set[str]]:
    """Module name -> the absolute names of every module it imports (relative imports resolved)."""
    out: dict[str, set[str]] = {}
    for package in packages:
        for path in sorted((root / package).rglob("*.py")):
            relative = path.relative_to(root).with_suffix("")
            parts = list(relative.parts)
            is_package = parts[-1] == "__init__"
            if is_package:
                parts = parts[:-1]
            name = ".".join(parts)
            here = parts if is_package else parts[:-1]
            found: set[str] = set()
            for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"), str(path))):
                if isinstance(node, ast.Import):
                    found |= {alias.name for alias in node.names}
                elif isinstance(node, ast.ImportFrom):
                    base = here[:len(here) - node.level + 1] if node.level else []
                    module = ".".join([*base, *(node.module.split(".") if node.module else [])])
                    found.add(module)
                    # "from . import x" and "from pkg import module" import submodules too
                    found |= {f"{module}.{alias.name}" for alias in node.names}
            out[name] = found
    return out


def violations(imports: dict[str, set[str]]) -> list[str]:
    """Every import that breaks the layer rules, as 'module -> imported: why'."""
    known = set(imports)
    problems = []
    for module, imported in sorted(imports.items()):
        package = module.split(".")[0]
        # One line per imported module: "from x import a, b" adds x.a and x.b, which may be names, not modules.
        for name in sorted(n for n in imported if n in known or "." not in n or n.rsplit(".", 1)[0] not in imported):
            top = name.split(".")[0]
            if top in LAYERS:
                if top != package and LAYERS[top] >= LAYERS[package]:
                    problems.append(f"{module} -> {name}: layer {LAYERS[package]} may not import layer "
                                    f"{LAYERS[top]} ({top})")
            elif top not in sys.stdlib_module_names and top != "__future__" and top not in THIRD_PARTY[package]:
                problems.append(f"{module} -> {name}: {package} may not depend on {top}")
            elif top == "ompl" and LAYERS[package] > LAYERS["solver"] and module not in OMPL_USERS_ABOVE_SOLVER:
                problems.append(f"{module} -> {name}: only the solver sets up OMPL")
    # Above the solver, a solver module that needs OMPL may only be used by a module that plans with OMPL.
    needs_ompl = {m for m in known if m.startswith("solver") and _reaches_ompl(m, imports)}
    for module, imported in sorted(imports.items()):
        if LAYERS[module.split(".")[0]] == 3 and module not in OMPL_USERS_ABOVE_SOLVER:
            for name in sorted(imported & needs_ompl):
                problems.append(f"{module} -> {name}: imports OMPL (use the solver's OMPL-free modules)")
    return problems


def _reaches_ompl(module: str, imports: dict[str, set[str]], seen: set[str] | None = None) -> bool:
    seen = set() if seen is None else seen
    if module in seen:
        return False
    seen.add(module)
    for name in imports.get(module, ()):
        if name.split(".")[0] == "ompl":
            return True
        if name in imports and _reaches_ompl(name, imports, seen):
            return True
    return False


def test_every_import_points_down_a_layer():
    problems = violations(module_imports(REPOSITORY))
    assert not problems, "imports against the architecture (../shared/DESIGN.md):\n" + "\n".join(problems)


def test_the_check_catches_an_upward_import(tmp_path):
    # The test above is only worth something if it can fail: plant each kind of bad import.
    for package in LAYERS:
        (tmp_path / package).mkdir()
        (tmp_path / package / "__init__.py").write_text("")
    (tmp_path / "phyrogen_core" / "chain.py").write_text("def f():\n    from solver import collision\n")
    (tmp_path / "phyrogen_core" / "fast.py").write_text("import numba\n")
    (tmp_path / "solver" / "cli.py").write_text("from blender_addon.gallery import write_gallery\n")
    (tmp_path / "solver" / "setup.py").write_text("from ompl import base\n")
    (tmp_path / "manipulation" / "run.py").write_text("from ..blender_addon import scene\nimport bpy\n")
    (tmp_path / "blender_addon" / "ui.py").write_text("from solver.setup import x\n")
    problems = violations(module_imports(tmp_path))
    for expected in ("phyrogen_core.chain -> solver", "phyrogen_core.fast -> numba", "solver.cli -> blender_addon",
                     "manipulation.run -> blender_addon", "manipulation.run -> bpy",
                     "blender_addon.ui -> solver.setup: imports OMPL"):
        assert any(p.startswith(expected) for p in problems), (expected, problems)


def test_the_core_imports_without_the_layers_above_it():
    import subprocess

    code = ("import sys, phyrogen_core, phyrogen_core.export, phyrogen_core.folder, phyrogen_core.registry;"
            "phyrogen_core.registry.all_generators();"
            "bad = sorted(m for m in sys.modules if m.split('.')[0] in "
            "('solver', 'blender_addon', 'manipulation', 'phyrogen', 'ompl', 'bpy', 'pybullet', 'numba'));"
            "assert not bad, bad")
    subprocess.run([sys.executable, "-c", code], check=True, cwd=REPOSITORY)
