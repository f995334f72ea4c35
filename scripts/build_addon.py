"""Build PhyRoGen's Blender add-on zips from ``blender_addon/``: ``python scripts/build_addon.py [--out DIR]``.

Two zips, each self-contained for Linux x86-64 and Python 3.11 (prints both paths):

- ``phyrogen-<version>.zip``, the extension for Blender 4.2+ (Edit > Preferences >
  Get Extensions > Install from Disk), built with Blender's own extension
  builder (shipped with the bpy wheel, or given with ``--builder``). Its
  manifest's ``wheels`` bundle what every panel button runs: PhyRoGen itself
  (a wheel built from this repository), OMPL, numba with llvmlite, tqdm,
  matplotlib (Benchmark's plots), pybullet, imageio and imageio-ffmpeg
  (Manipulate's simulation, frames and video), at the versions
  ``pyproject.toml`` pins, and what they require. numpy is not bundled: Blender
  ships it (1.x in 4.2 to 4.5), and a second copy would shadow Blender's own for
  every add-on (extensions' wheels come first on sys.path).
- ``phyrogen-<version>-legacy.zip``, the legacy add-on for Blender 3.x (Edit >
  Preferences > Add-ons > Install): one folder, ``phyrogen_blender/``, with
  ``bl_info`` in its ``__init__.py`` and the same wheels unpacked into
  ``phyrogen_blender/site-packages/``, numpy included (Debian's Blender 3.4 has
  none). The add-on appends that folder to ``sys.path`` (after Blender's own, so
  a Blender's numpy wins) and puts it on its workers' ``PYTHONPATH``.

Wheels are downloaded once into ``build/wheels`` (git-ignored; ``--wheels DIR``
for another cache); later builds work offline. ``--no-wheels`` builds thin zips
that need PhyRoGen's virtual environment (``PHYROGEN_VENV``).
"""

from __future__ import annotations

import argparse
import functools
import re
import shutil
import subprocess
import sys
import tempfile
import tomllib
import zipfile
from pathlib import Path

REPOSITORY = Path(__file__).resolve().parent.parent
SOURCE = REPOSITORY / "blender_addon"
WHEEL_CACHE = REPOSITORY / "build" / "wheels"

BUNDLED = ("ompl", "numba", "tqdm", "matplotlib", "pybullet", "imageio", "imageio-ffmpeg")
"""Project dependencies the panel's buttons import: Generate, Re-plan (OMPL, numba; llvmlite comes with
numba), Benchmark (matplotlib's plots), Manipulate (pybullet; imageio and imageio-ffmpeg write its frames
and video)."""
EXTRAS = ("manipulation",)
"""Optional dependency groups of ``pyproject.toml`` that the panel needs (Manipulate's frames and video)."""
PROVIDED_BY_BLENDER = ("numpy",)
"""Resolved with the bundle (numba needs a compatible one) but not in the extension: Blender 4.2+ ships
them. The legacy zip bundles them too (appended to sys.path, so a Blender's own copy wins)."""
NOT_BUNDLED = {
    "numpy": "Blender 4.2+ ships numpy (1.x in Blender 4.2 to 4.5); in the extension a bundled copy would "
             "shadow Blender's own",
}
"""Why each project dependency outside ``BUNDLED`` stays out of the extension (a test checks the list is complete)."""
LEGACY_MODULE = "phyrogen_blender"
"""The legacy add-on's folder and module name: not ``phyrogen``, the command line's package, which the
bundled site-packages also holds."""
PLATFORM = "linux-x64"
WHEEL_PLATFORMS = ("manylinux_2_28_x86_64", "manylinux2014_x86_64")  # Blender 4.2+ on Linux needs glibc 2.28
PYTHON_VERSION = "3.11"  # Blender 4.2 to 4.5 (and the bpy 4.5 wheel)


def find_builder() -> Path:
    """``blender_ext.py`` of the installed bpy wheel."""
    import importlib.util

    spec = importlib.util.find_spec("bpy")
    if spec is None or spec.origin is None:
        raise FileNotFoundError("the bpy wheel is not installed (pip install -e .[blender]); "
                                "or pass --builder PATH/TO/blender_ext.py")
    found = sorted(Path(spec.origin).parent.glob("*/scripts/addons_core/bl_pkg/cli/blender_ext.py"))
    if not found:
        raise FileNotFoundError(f"no blender_ext.py under {Path(spec.origin).parent}; pass --builder")
    return found[-1]


def project_requirements() -> dict[str, str]:
    """``pyproject.toml``'s dependencies and those of :data:`EXTRAS`, by lower-case distribution name ->
    requirement string."""
    project = tomllib.loads((REPOSITORY / "pyproject.toml").read_text(encoding="utf-8"))["project"]
    dependencies = [*project["dependencies"],
                    *(r for extra in EXTRAS for r in project["optional-dependencies"][extra])]
    return {re.split(r"[<>=!~ \[;]", requirement, maxsplit=1)[0].lower(): requirement
            for requirement in dependencies}


def distribution_name(wheel: Path) -> str:
    """The normalised distribution name of a wheel file (``numba-0.61.2-cp311-...whl`` -> ``numba``)."""
    return wheel.name.split("-")[0].lower().replace("_", "-")


def _pip(arguments: list[str]) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "pip", *arguments, "--disable-pip-version-check"],
                          capture_output=True, text=True)


def dependency_wheels(cache: Path, provided: bool = False) -> list[Path]:
    """Wheels of ``BUNDLED`` and what they need for Blender's Python on Linux x86-64, from ``cache``
    (downloaded into it when missing); those of ``PROVIDED_BY_BLENDER`` only with ``provided``."""
    return [w for w in _resolved_wheels(cache) if provided or distribution_name(w) not in PROVIDED_BY_BLENDER]


@functools.cache
def _resolved_wheels(cache: Path) -> tuple[Path, ...]:
    """Every wheel :func:`dependency_wheels` may return, resolved once per process (both zips need the
    same resolution; each pip run takes seconds)."""
    requirements = project_requirements()
    missing = [name for name in (*BUNDLED, *PROVIDED_BY_BLENDER) if name not in requirements]
    if missing:
        raise RuntimeError(f"pyproject.toml no longer lists {missing}; update BUNDLED in {Path(__file__).name}")
    wanted = [requirements[name] for name in (*BUNDLED, *PROVIDED_BY_BLENDER)]
    cache.mkdir(parents=True, exist_ok=True)
    platforms = [argument for platform in WHEEL_PLATFORMS for argument in ("--platform", platform)]
    target = ["--only-binary=:all:", *platforms, "--python-version", PYTHON_VERSION,
              "--implementation", "cp", "--abi", f"cp{PYTHON_VERSION.replace('.', '')}", "--dest", str(cache)]
    # The cache first, so that a second build needs no network; the index when something is missing.
    result = _pip(["download", "--quiet", "--no-index", "--find-links", str(cache), *target, *wanted])
    if result.returncode != 0:
        result = _pip(["download", "--quiet", *target, *wanted])
    if result.returncode != 0:
        raise RuntimeError(f"could not download the wheels to bundle ({' '.join(wanted)}) into {cache}: "
                           f"{result.stderr.strip().splitlines()[-1:]}; with no network, build the thin zip "
                           "with --no-wheels (it needs PHYROGEN_VENV)")
    # pip reports what it resolved as "Saved ..." or "File was already downloaded ..." lines only
    # without --quiet; the resolution is asked again, offline, to learn which files it chose.
    listing = _pip(["download", "--no-index", "--find-links", str(cache), *target, *wanted])
    chosen = sorted({Path(match) for match in re.findall(r"(\S+\.whl)", listing.stdout)}, key=lambda p: p.name)
    wheels = [cache / path.name for path in chosen if (cache / path.name).is_file()]
    found = {distribution_name(w) for w in wheels}
    if listing.returncode != 0 or not set(BUNDLED) <= found:
        raise RuntimeError(f"the wheels in {cache} do not cover {list(BUNDLED)} (found {sorted(found)}): "
                           f"{listing.stdout[-500:]}{listing.stderr[-500:]}")
    return tuple(wheels)


PROJECT_FILES = ("pyproject.toml", "README.md", "LICENSE")


def project_wheel(out_dir: Path) -> Path:
    """A wheel of PhyRoGen itself (``phyrogen``, ``phyrogen_core``, ``solver``, ...) built from this repository.

    Built from a clean copy of the packages ``pyproject.toml`` names, so that no ``build/lib`` left
    by an earlier build can put a deleted module back, and nothing is written into the repository.
    """
    source = out_dir / "source"
    source.mkdir(parents=True)
    for name in PROJECT_FILES:
        shutil.copy2(REPOSITORY / name, source / name)
    include = tomllib.loads((REPOSITORY / "pyproject.toml").read_text(encoding="utf-8"))
    patterns = include["tool"]["setuptools"]["packages"]["find"]["include"]
    packages = {pattern.split(".")[0].rstrip("*") for pattern in patterns}
    for package in sorted(packages):
        shutil.copytree(REPOSITORY / package, source / package, ignore=shutil.ignore_patterns("__pycache__", "*.pyc"))
    result = _pip(["wheel", "--quiet", "--no-deps", "--wheel-dir", str(out_dir), str(source)])
    wheels = sorted(out_dir.glob("phyrogen-*.whl"))
    if result.returncode != 0 or not wheels:
        raise RuntimeError(f"building PhyRoGen's wheel failed ({result.returncode}): {result.stderr[-1000:]}")
    return wheels[-1]


def manifest_with_wheels(manifest: str, wheels: list[str]) -> str:
    """The manifest text with ``platforms`` and ``wheels`` added as top-level keys (before the first table)."""
    keys = (f'platforms = ["{PLATFORM}"]\n'
            "wheels = [\n" + "".join(f'  "./wheels/{name}",\n' for name in wheels) + "]\n\n")
    lines = manifest.splitlines(keepends=True)
    first_table = next((i for i, line in enumerate(lines) if line.lstrip().startswith("[")), len(lines))
    return "".join(lines[:first_table]) + keys + "".join(lines[first_table:])


def build(out_dir: Path, builder: Path | None = None, wheels: bool = True, cache: Path = WHEEL_CACHE,
          project: Path | None = None) -> Path:
    """Build the zip into ``out_dir`` and return its path; ``wheels``: bundle the dependencies (see above);
    ``project``: PhyRoGen's wheel, already built by :func:`project_wheel` (else built here)."""
    builder = builder or find_builder()
    out_dir.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory() as staging:
        # Build from a clean copy: no caches, nothing a developer left beside the sources.
        source = Path(staging) / "phyrogen"
        shutil.copytree(SOURCE, source, ignore=shutil.ignore_patterns("__pycache__", "*.pyc"))
        if wheels:
            folder = source / "wheels"
            folder.mkdir()
            for wheel in [*dependency_wheels(cache), project or project_wheel(Path(staging) / "project")]:
                shutil.copy2(wheel, folder / wheel.name)
            manifest = source / "blender_manifest.toml"
            manifest.write_text(manifest_with_wheels(manifest.read_text(encoding="utf-8"),
                                                     sorted(p.name for p in folder.iterdir())), encoding="utf-8")
        result = subprocess.run([sys.executable, str(builder), "build", "--source-dir", str(source),
                                 "--output-dir", str(out_dir)], capture_output=True, text=True)
    if result.returncode != 0:
        raise RuntimeError(f"extension build failed ({result.returncode}): {result.stdout}{result.stderr}")
    zips = sorted((p for p in out_dir.glob("phyrogen-*.zip") if not p.name.endswith("-legacy.zip")),
                  key=lambda p: p.stat().st_mtime)
    if not zips:
        raise RuntimeError(f"the builder wrote no zip into {out_dir}: {result.stdout}")
    return zips[-1]


def unpack_wheel(wheel: Path, site_packages: Path) -> None:
    """Install ``wheel`` into ``site_packages`` as pip would for a pure/platlib wheel: its files, with
    ``<name>.data/purelib`` and ``platlib`` merged in (scripts and data files are not needed)."""
    with zipfile.ZipFile(wheel) as archive:
        for member in archive.infolist():
            parts = Path(member.filename).parts
            if parts and parts[0].endswith(".data"):
                if len(parts) < 3 or parts[1] not in ("purelib", "platlib"):
                    continue
                target = site_packages.joinpath(*parts[2:])
            else:
                target = site_packages / member.filename
            if member.is_dir():
                target.mkdir(parents=True, exist_ok=True)
                continue
            target.parent.mkdir(parents=True, exist_ok=True)
            with archive.open(member) as source, open(target, "wb") as out:
                shutil.copyfileobj(source, out)
            mode = (member.external_attr >> 16) & 0o777
            if mode:
                target.chmod(mode | 0o644)


def build_legacy(out_dir: Path, wheels: bool = True, cache: Path = WHEEL_CACHE, project: Path | None = None) -> Path:
    """Build the legacy add-on zip for Blender 3.x into ``out_dir`` and return its path (see above);
    ``project`` as for :func:`build`."""
    manifest = tomllib.loads((SOURCE / "blender_manifest.toml").read_text(encoding="utf-8"))
    out_dir.mkdir(parents=True, exist_ok=True)
    target = out_dir / f"phyrogen-{manifest['version']}-legacy.zip"
    with tempfile.TemporaryDirectory() as staging:
        root = Path(staging) / LEGACY_MODULE
        shutil.copytree(SOURCE, root, ignore=shutil.ignore_patterns("__pycache__", "*.pyc", "blender_manifest.toml"))
        if wheels:
            site_packages = root / "site-packages"
            for wheel in [*dependency_wheels(cache, provided=True),
                          project or project_wheel(Path(staging) / "project")]:
                unpack_wheel(wheel, site_packages)
        temporary = target.with_name(f".{target.name}.tmp")
        with zipfile.ZipFile(temporary, "w", zipfile.ZIP_DEFLATED, compresslevel=1) as archive:
            for path in sorted(root.rglob("*")):
                if path.is_file():
                    info = zipfile.ZipInfo.from_file(path, path.relative_to(staging).as_posix())
                    info.compress_type = zipfile.ZIP_DEFLATED
                    with open(path, "rb") as source:
                        archive.writestr(info, source.read())
        temporary.replace(target)
    return target


KINDS = ("both", "extension", "legacy")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default="dist", help="output folder (default: dist)")
    parser.add_argument("--kind", choices=KINDS, default="both",
                        help="the extension zip (Blender 4.2+), the legacy add-on zip (Blender 3.x), or both "
                             "(default; one path per line, the extension's first)")
    parser.add_argument("--builder", type=Path, help="Blender's blender_ext.py (default: the bpy wheel's)")
    parser.add_argument("--wheels", type=Path, default=WHEEL_CACHE,
                        help="cache of the wheels to bundle (default: build/wheels; downloaded when missing)")
    parser.add_argument("--no-wheels", action="store_true",
                        help="bundle nothing: thin zips, which need PhyRoGen's environment (PHYROGEN_VENV)")
    args = parser.parse_args(argv)
    try:
        with tempfile.TemporaryDirectory() as staging:
            # Both zips bundle the same wheel of PhyRoGen: built once (pip wheel takes seconds).
            project = project_wheel(Path(staging)) if args.kind == "both" and not args.no_wheels else None
            if args.kind in ("both", "extension"):
                print(build(Path(args.out), args.builder, wheels=not args.no_wheels, cache=args.wheels,
                            project=project))
            if args.kind in ("both", "legacy"):
                print(build_legacy(Path(args.out), wheels=not args.no_wheels, cache=args.wheels, project=project))
    except (FileNotFoundError, RuntimeError) as exc:
        print(f"build_addon: error: {exc}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
