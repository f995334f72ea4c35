"""Install Phobos (github.com/dfki-ric/phobos) into a Blender with its requirements, and enable it.

    python scripts/install_phobos.py --blender blender --phobos PHOBOS [--replace]

PHOBOS is Phobos's source as its repository gives it: a checkout folder, or a
``.zip`` / ``.tar.gz`` of one (GitHub's "Download ZIP"); 2.1.0 was tested.
Phobos is not on a package index and is never bundled with PhyRoGen.

Phobos installs its requirements itself on its first start by running
``<Blender's Python> -m pip install --upgrade pip``; a Blender that runs the
system's Python (Debian's ``blender``) refuses that (PEP 668,
``externally-managed-environment``) and Phobos does not enable. Unpinned, its
requirements also bring NumPy 2.x into Blender's process, where PhyRoGen's
Numba (0.61) refuses to load ("Numba needs NumPy 2.2 or less"). This script
does what Phobos's README does, in a way that works there:

1. asks BLENDER for its Python (version, interpreter) and its user scripts
   folder (``$BLENDER_USER_SCRIPTS`` when set, else Blender's default);
2. installs Phobos's requirements at versions that keep PhyRoGen working
   (:data:`REQUIREMENTS`: NumPy below 2) with ``pip install --target`` into
   ``<scripts>/modules``, which Blender puts first on ``sys.path`` at start
   (``--target`` installs into no Python's own site-packages, which is what
   PEP 668 protects). pip runs in Blender's own interpreter when it has pip
   (Debian's ``python3-pip``), else in this script's Python when its version
   is Blender's;
3. copies Phobos's ``phobos/`` package folder to ``<scripts>/addons/phobos``
   (an existing one is replaced only with ``--replace``);
4. starts BLENDER once more, checks that every requirement imports there
   (with one missing, Phobos would run pip itself and open a popup that
   crashes a background Blender), enables Phobos and saves the preferences.

Bad input (no such Blender, no Phobos in PHOBOS, an existing Phobos without
``--replace``) is one line on stderr and exit 2, before anything is written.
A step that fails says which (exit 1); the add-on folder is swapped in whole,
so an interrupted run leaves no half-copied Phobos.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import tarfile
import tempfile
import zipfile
from pathlib import Path

REQUIREMENTS = ("pyyaml", "numpy>=1.24,<2", "scipy>=1.10,<1.15", "setuptools<80", "pycollada", "pydot", "lxml",
                "networkx", "trimesh", "Pillow")
"""Phobos's requirements and optional requirements (``phobos/__init__.py``), pinned where it matters: NumPy
below 2 (PyPI's newest, 2.4, stops Numba 0.61 in the same process; PhyRoGen pins numpy<2 as the bpy 4.5
wheel needs), a SciPy built for NumPy 1.x, and a setuptools that still has ``pkg_resources`` (Phobos
imports it; setuptools 80 removed it)."""
IMPORTS = ("yaml", "numpy", "scipy", "pkg_resources", "collada", "pydot", "lxml", "networkx", "trimesh", "PIL")
"""What Phobos imports of them (its ``requirements`` and ``optional_requirements`` keys)."""
MARK = "PHYROGEN-INSTALL-PHOBOS "
TIMEOUT = 600

_ASK = ("import bpy, json, sys; print({mark!r} + json.dumps({{'python': list(sys.version_info[:2]), "
        "'executable': sys.executable, 'scripts': bpy.utils.user_resource('SCRIPTS'), "
        "'blender': bpy.app.version_string}}))")
_ENABLE = """
import bpy, importlib, json, sys
out = {{"missing": []}}
for name in {imports!r}:
    try:
        importlib.import_module(name)
    except Exception as exc:
        out["missing"].append(f"{{name}} ({{type(exc).__name__}}: {{exc}})")
if not out["missing"]:
    import numpy
    out["numpy"] = numpy.__version__
    bpy.ops.preferences.addon_enable(module="phobos")
    out["enabled"] = "phobos" in bpy.context.preferences.addons
    if out["enabled"]:
        bpy.ops.wm.save_userpref()
print({mark!r} + json.dumps(out))
"""


class BadInputError(Exception):
    """A command-line value that cannot work (exit 2)."""


class StepError(Exception):
    """A step that ran and failed (exit 1)."""


def blender_answer(blender: str, expression: str, *, factory: bool) -> dict:
    """Run ``expression`` in a background BLENDER and return the JSON it printed after :data:`MARK`."""
    command = [blender, "--background", *(["--factory-startup"] if factory else []), "--python-exit-code", "1",
               "--python-expr", expression]
    try:
        run = subprocess.run(command, capture_output=True, text=True, timeout=TIMEOUT)
    except OSError as exc:
        raise BadInputError(f"--blender {blender}: cannot run it: {exc.strerror or exc}") from None
    for line in run.stdout.splitlines():
        if line.startswith(MARK):
            return json.loads(line[len(MARK):])
    last = (run.stderr.strip() or run.stdout.strip() or "no output").splitlines()[-1]
    raise StepError(f"{blender} did not answer (exit {run.returncode}): {last}")


def phobos_package(source: Path, into: Path) -> Path:
    """Phobos's ``phobos/`` package folder from a checkout, a .zip or a .tar.gz (unpacked under ``into``)."""
    if source.is_dir():
        root = source
    elif source.is_file() and zipfile.is_zipfile(source):
        with zipfile.ZipFile(source) as archive:
            archive.extractall(into)
        root = into
    elif source.is_file() and tarfile.is_tarfile(source):
        with tarfile.open(source) as archive:
            archive.extractall(into, filter="data")
        root = into
    else:
        raise BadInputError(f"--phobos {source}: not a Phobos checkout folder, .zip or .tar.gz")
    found = sorted((p.parent for p in root.glob("**/phobos/__init__.py") if (p.parent / "blender").is_dir()),
                   key=lambda p: len(p.parts))
    if not found or "bl_info" not in (found[0] / "__init__.py").read_text(encoding="utf-8", errors="replace"):
        raise BadInputError(f"--phobos {source}: no Phobos add-on in it (a phobos/ folder with blender/)")
    return found[0]


def pip_python(blender_python: str, version: tuple[int, int]) -> str:
    """An interpreter with pip for Blender's Python version: Blender's own, else this one."""
    for python in (blender_python, sys.executable):
        if not python or not os.path.exists(python):
            continue
        probe = subprocess.run([python, "-c", "import sys, pip; print(*sys.version_info[:2])"],
                               capture_output=True, text=True)
        if probe.returncode == 0 and tuple(map(int, probe.stdout.split())) == tuple(version):
            return python
    major, minor = version
    raise BadInputError(f"no Python {major}.{minor} with pip found to install Phobos's requirements for this Blender "
                   f"(tried {blender_python} and {sys.executable}); install python{major}.{minor}'s pip "
                   "(Debian: apt install python3-pip) or run this script with such a Python")


def install_requirements(python: str, modules: Path) -> None:
    """pip install :data:`REQUIREMENTS` with ``--target modules`` (PEP 668 does not apply there)."""
    modules.mkdir(parents=True, exist_ok=True)
    command = [python, "-m", "pip", "install", "--disable-pip-version-check", "--no-input", "--upgrade",
               "--target", str(modules), *REQUIREMENTS]
    print(f"install_phobos: {' '.join(command)}", flush=True)
    run = subprocess.run(command, capture_output=True, text=True, timeout=TIMEOUT)
    if run.returncode != 0:
        last = (run.stderr.strip() or "no output").splitlines()[-1]
        raise StepError(f"pip could not install Phobos's requirements into {modules}: {last}")


def copy_addon(package: Path, addons: Path) -> Path:
    """``package`` copied to ``addons/phobos``, swapped in whole (an old one goes only after the copy is done)."""
    addons.mkdir(parents=True, exist_ok=True)
    target = addons / "phobos"
    staging = Path(tempfile.mkdtemp(prefix=".phobos-", dir=addons))
    try:
        shutil.copytree(package, staging / "phobos", ignore=shutil.ignore_patterns("__pycache__"))
        if target.exists():
            old = staging / "old"
            target.rename(old)
        (staging / "phobos").rename(target)
    finally:
        shutil.rmtree(staging, ignore_errors=True)
    return target


class _Parser(argparse.ArgumentParser):
    """argparse, but a bad argument is one line on stderr and exit 2 (the project's contract), not the usage too."""

    def error(self, message: str):
        self.exit(2, f"install_phobos: error: {message}\n")


def main(argv: list[str]) -> int:
    parser = _Parser(prog="install_phobos.py", description=__doc__.split("\n\n")[0])
    parser.add_argument("--blender", default="blender", help="the Blender binary (default: blender on PATH)")
    parser.add_argument("--phobos", required=True, type=Path,
                        help="Phobos's source: a checkout folder, or a .zip / .tar.gz of one")
    parser.add_argument("--replace", action="store_true", help="replace a Phobos already in the add-on folder")
    args = parser.parse_args(argv)
    try:
        blender = shutil.which(args.blender)
        if blender is None:
            raise BadInputError(f"--blender {args.blender}: no such program")
        with tempfile.TemporaryDirectory(prefix="phyrogen-phobos-source-") as unpacked:
            package = phobos_package(args.phobos, Path(unpacked))
            facts = blender_answer(blender, _ASK.format(mark=MARK), factory=True)
            scripts = Path(facts["scripts"])
            addon = scripts / "addons" / "phobos"
            if addon.exists() and not args.replace:
                raise BadInputError(f"{addon} exists already (a Phobos installed before?); --replace replaces it")
            python = pip_python(facts["executable"], tuple(facts["python"]))
            install_requirements(python, scripts / "modules")
            copy_addon(package, scripts / "addons")
        enabled = blender_answer(blender, _ENABLE.format(imports=IMPORTS, mark=MARK), factory=False)
        if enabled["missing"]:
            raise StepError(f"Blender cannot import Phobos's requirements: {'; '.join(enabled['missing'])}")
        if not enabled.get("enabled"):
            raise StepError(f"Blender {facts['blender']} did not enable Phobos (see its console output)")
    except BadInputError as exc:
        print(f"install_phobos: error: {exc}", file=sys.stderr)
        return 2
    except (StepError, OSError, subprocess.SubprocessError) as exc:
        print(f"install_phobos: error: {exc}", file=sys.stderr)
        return 1
    print(f"install_phobos: Phobos installed in {addon} and enabled in Blender {facts['blender']} "
          f"(requirements in {scripts / 'modules'}, NumPy {enabled['numpy']})")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
