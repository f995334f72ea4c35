"""Dependencies point one way: core <- solver <- {blender_addon, manipulation} <- phyrogen (the command line).

Every module's imports are read from its source (function-level imports
too), so a lazy import that points up a layer fails here as well.
"""

from __future__ import annotations

import ast
import re
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
    "manipulation": {"numpy", "numba", "pybullet", "pybullet_data", "imageio", "tqdm", "ompl",
                     "mujoco"},  # mjcf_rollout: the exported MJCF rolled out through its servos
    "phyrogen": {"tqdm", "numpy", "gymnasium"},
}
"""Outside the standard library, what each package may import."""

SOLVER_LAYERS = {"collision": 1, "parallel": 1, "planning": 2, "validation": 3, "benchmark": 4, "pipelines": 5}
"""Inside the solver the same rule, one level down: a subpackage may import lower ones and itself.

collision and parallel are the ground floor (the exact collision model; worker processes and Ray),
planning builds the OMPL-free problem and the planners on collision, validation asks planners whether
a puzzle is solvable (the Maker's validator and necessity judge), benchmark runs planners against each
other, and pipelines (generation, dataset, audit, import, replan) put all of them to work.
"""

OMPL_USERS_ABOVE_SOLVER = {"manipulation.reaching": "plans the arm's reaching motions with OMPL's BIT*",
                           "manipulation.source": "runs a short LA-RRT benchmark for a puzzle's default solution"}
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
    problems += _solver_violations(imports)
    # Above the solver, a solver module that needs OMPL may only be used by a module that plans with OMPL.
    needs_ompl = {m for m in known if m.startswith("solver") and _reaches_ompl(m, imports)}
    for module, imported in sorted(imports.items()):
        if LAYERS[module.split(".")[0]] == 3 and module not in OMPL_USERS_ABOVE_SOLVER:
            for name in sorted(imported & needs_ompl):
                problems.append(f"{module} -> {name}: imports OMPL (use the solver's OMPL-free modules)")
    return problems


def _solver_violations(imports: dict[str, set[str]]) -> list[str]:
    """Imports between the solver's subpackages against :data:`SOLVER_LAYERS`, and solver modules
    outside every subpackage (each concern has its folder)."""
    problems = []
    for module, imported in sorted(imports.items()):
        parts = module.split(".")
        if parts[0] != "solver" or len(parts) == 1:
            continue
        if parts[1] not in SOLVER_LAYERS:
            problems.append(f"{module}: a solver module outside the subpackages {sorted(SOLVER_LAYERS)}")
            continue
        for name in sorted(n for n in imported if n.split(".")[0] == "solver" and len(n.split(".")) > 1):
            other = name.split(".")[1]
            if other in SOLVER_LAYERS and other != parts[1] and SOLVER_LAYERS[other] >= SOLVER_LAYERS[parts[1]]:
                problems.append(f"{module} -> {name}: solver.{parts[1]} (level {SOLVER_LAYERS[parts[1]]}) may not "
                                f"import solver.{other} (level {SOLVER_LAYERS[other]})")
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
    for sub in ("collision", "pipelines"):
        (tmp_path / "solver" / sub).mkdir()
        (tmp_path / "solver" / sub / "__init__.py").write_text("")
    (tmp_path / "solver" / "collision" / "model.py").write_text("from solver.pipelines.audit import run\n")
    (tmp_path / "solver" / "pipelines" / "audit.py").write_text("from ..collision.model import x\n")
    problems = violations(module_imports(tmp_path))
    for expected in ("phyrogen_core.chain -> solver", "phyrogen_core.fast -> numba", "solver.cli -> blender_addon",
                     "manipulation.run -> blender_addon", "manipulation.run -> bpy",
                     "blender_addon.ui -> solver.setup: imports OMPL",
                     "solver.collision.model -> solver.pipelines.audit: solver.collision (level 1) may not",
                     "solver.cli: a solver module outside the subpackages"):
        assert any(p.startswith(expected) for p in problems), (expected, problems)


def test_a_subpackage_init_imports_nothing():
    # Importing solver.planning.problem runs solver/__init__.py and solver/planning/__init__.py first:
    # an import there would load siblings (OMPL among them) into every user of one module.
    for init in sorted((REPOSITORY / "solver").rglob("__init__.py")):
        if init.parent.name == "dataset":
            continue  # the dataset package's public names, all of its own level
        tree = ast.parse(init.read_text(encoding="utf-8"))
        assert not [n for n in ast.walk(tree) if isinstance(n, ast.Import | ast.ImportFrom)
                    and not (isinstance(n, ast.ImportFrom) and n.module == "__future__")], init


def test_the_core_imports_without_the_layers_above_it():
    import subprocess

    code = ("import sys, phyrogen_core, phyrogen_core.export, phyrogen_core.folder, phyrogen_core.registry;"
            "phyrogen_core.registry.all_generators();"
            "bad = sorted(m for m in sys.modules if m.split('.')[0] in "
            "('solver', 'blender_addon', 'manipulation', 'phyrogen', 'ompl', 'bpy', 'pybullet', 'numba'));"
            "assert not bad, bad")
    subprocess.run([sys.executable, "-c", code], check=True, cwd=REPOSITORY)


# -- docs/architecture.md says what the code does -------------------------------------------------
ARCHITECTURE = REPOSITORY / "docs" / "architecture.md"


def _ompl_users_above_solver(imports: dict[str, set[str]]) -> set[str]:
    """The layer-3 modules that import OMPL themselves or a solver module that reaches it."""
    needs_ompl = {m for m in imports if m.startswith("solver") and _reaches_ompl(m, imports)}
    return {module for module, imported in imports.items() if LAYERS[module.split(".")[0]] == 3
            and any(n.split(".")[0] == "ompl" or n in needs_ompl for n in imported)}


def _documented_ompl_users(text: str) -> set[str]:
    bullet = next(part for part in text.split("\n- ") if part.startswith("Layer-3 packages"))
    return set(re.findall(r"`((?:manipulation|blender_addon)\.\w+)`", bullet))


def test_the_documented_ompl_exceptions_are_the_codes():
    imports = module_imports(REPOSITORY)
    real = _ompl_users_above_solver(imports)
    # The exceptions the layer check allows are the modules that need them, and the page names them all.
    assert real == set(OMPL_USERS_ABOVE_SOLVER), (real, sorted(OMPL_USERS_ABOVE_SOLVER))
    assert _documented_ompl_users(ARCHITECTURE.read_text(encoding="utf-8")) == real
    # Negative control: a manipulation module that stopped reaching OMPL would leave a stale exception.
    imports["manipulation.source"] = {"phyrogen_core.folder"}
    assert "manipulation.source" not in _ompl_users_above_solver(imports)


def test_the_local_pool_never_imports_ray():
    imports = module_imports(REPOSITORY, ("solver",))
    assert not {n for n in imports["solver.parallel.pool"] if n.startswith("solver.parallel.ray_pool")}
    assert "solver.parallel.pool" in imports["solver.parallel.ray_pool"]  # the one way the page states


def _defines(root: Path, module: str, name: str) -> bool:
    path = root / Path(*module.split("."))
    path = path / "__init__.py" if path.is_dir() else path.with_suffix(".py")
    tree = ast.parse(path.read_text(encoding="utf-8"))
    for node in tree.body:
        if isinstance(node, ast.FunctionDef | ast.ClassDef) and node.name == name:
            return True
        targets = node.targets if isinstance(node, ast.Assign) else [node.target] if isinstance(
            node, ast.AnnAssign) else []
        if any(isinstance(t, ast.Name) and t.id == name for t in targets):
            return True
    return False


def unknown_names(text: str, root: Path) -> list[str]:
    """The modules the architecture page names that do not exist: the core's row and the solver
    table's modules, and every backticked dotted name of a package (a module, ``module.*``, or a
    module's function, class or constant)."""
    def exists(*parts: str) -> bool:
        path = root.joinpath(*parts)
        return path.is_dir() or path.with_suffix(".py").is_file()

    missing = []
    for line in text.splitlines():
        cells = [cell.strip() for cell in line.split("|")]
        if len(cells) < 5 or not cells[1].isdigit():
            continue
        package, holds = cells[2].strip("`"), cells[3]
        if package == "phyrogen_core/":
            missing += [f"phyrogen_core.{n}" for n in re.findall(r"`(\w+)`", holds) if not exists("phyrogen_core", n)]
        elif package.startswith("solver."):
            sub = package.split(".")[1]
            missing += [f"{package}.{n}" for n in re.findall(r"`(\w+)/?`", holds) if not exists("solver", sub, n)]
    for name in sorted(set(re.findall(rf"`((?:{'|'.join(LAYERS)})(?:\.[\w*]+)+)`", text))):
        parts = [p for p in name.split(".") if p != "*"]
        if exists(*parts):
            continue
        if not (exists(*parts[:-1]) and _defines(root, ".".join(parts[:-1]), parts[-1])):
            missing.append(name)
    return missing


def test_every_module_the_architecture_page_names_exists():
    text = ARCHITECTURE.read_text(encoding="utf-8")
    assert not unknown_names(text, REPOSITORY)
    # Negative control: a module that was split away, in a table and in the text, is found.
    planted = (text.replace("`sizes`", "`folder_sizes`")
               .replace("`solver.parallel.tasks.task_pool`", "`solver.parallel.tasks.pick_pool`")
               .replace("`goal_sampling`", "`goal_samples`"))
    assert unknown_names(planted, REPOSITORY) == ["phyrogen_core.folder_sizes", "solver.planning.goal_samples",
                                                  "solver.parallel.tasks.pick_pool"]


LONGEST_MODULE = 600
"""Lines a product module may have: past it a file mixes jobs that a newcomer must read apart."""


def long_modules(root: Path) -> list[str]:
    """The product's Python files (the layers' packages) longer than :data:`LONGEST_MODULE` lines."""
    found = []
    for package in LAYERS:
        for path in sorted((root / package).rglob("*.py")):
            lines = path.read_text(encoding="utf-8").count("\n")
            if lines > LONGEST_MODULE:
                found.append(f"{path.relative_to(root)}: {lines} lines")
    return found


def test_no_product_module_is_longer_than_the_limit(tmp_path):
    assert not long_modules(REPOSITORY), long_modules(REPOSITORY)
    # the control: a module one line past the limit is named
    (tmp_path / "solver").mkdir()
    (tmp_path / "solver" / "long.py").write_text("x = 1\n" * (LONGEST_MODULE + 1))
    (tmp_path / "solver" / "short.py").write_text("x = 1\n" * LONGEST_MODULE)
    assert long_modules(tmp_path) == [f"{Path('solver', 'long.py')}: {LONGEST_MODULE + 1} lines"]
