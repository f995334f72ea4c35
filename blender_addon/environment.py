"""Finding PhyRoGen's Python environment from inside a Blender binary.

A Blender binary embeds its own Python (with numpy) without OMPL, numba or our
packages. Two things supply them:

- the extension zip's bundled wheels (``scripts/build_addon.py``), which
  Blender 4.2+ installs into its extensions' site-packages and puts on
  ``sys.path``: nothing to find, but worker processes started with Blender's
  own Python need that folder on their ``PYTHONPATH`` (:func:`share_with_workers`);
- the legacy add-on zip's ``site-packages`` folder beside this file (Blender
  3.x installs no wheels): appended to ``sys.path`` here, after Blender's own
  folders, and shared with the workers the same way;
- the project's virtual environment ($PHYROGEN_VENV, or ``.venv`` beside a
  checkout): its site-packages are added with :func:`site.addsitedir` so that
  ``.pth`` files (the editable install of PhyRoGen itself) are honoured, and
  its Python runs the workers.

No bpy here: entry scripts call this first.
"""

from __future__ import annotations

import importlib.util
import os
import site
import sys
from pathlib import Path

REPOSITORY = Path(__file__).resolve().parent.parent
ENVIRONMENT_VARIABLE = "PHYROGEN_VENV"
BUNDLED_SITE_PACKAGES = Path(__file__).resolve().parent / "site-packages"
"""The legacy add-on zip's unpacked wheels (``scripts/build_addon.py``); absent in a checkout and the extension."""


def candidate_environments() -> list[Path]:
    """Virtual environments to try, most explicit first."""
    out = []
    for variable in (ENVIRONMENT_VARIABLE, "VIRTUAL_ENV"):
        value = os.environ.get(variable)
        if value:
            out.append(Path(value))
    out.append(REPOSITORY / ".venv")
    return out


def site_packages(environment: Path) -> Path | None:
    """The site-packages folder of ``environment`` for this interpreter's Python version."""
    version = f"python{sys.version_info.major}.{sys.version_info.minor}"
    path = environment / "lib" / version / "site-packages"
    return path if path.is_dir() else None


def find_environment() -> Path | None:
    """The first candidate environment that has site-packages for this Python version."""
    for environment in candidate_environments():
        if site_packages(environment) is not None:
            return environment
    return None


def ensure_project_importable() -> None:
    """Make ``phyrogen_core`` and ``solver`` (and numpy, ompl) importable, or say how to.

    Raises ImportError naming the environments that were tried.
    """
    if BUNDLED_SITE_PACKAGES.is_dir() and str(BUNDLED_SITE_PACKAGES) not in sys.path:
        site.addsitedir(str(BUNDLED_SITE_PACKAGES))  # appended: a Blender's own numpy comes first
    make_bundled_binaries_executable()
    try:
        import numpy  # noqa: F401

        import phyrogen_core  # noqa: F401
        share_with_workers()
        return
    except ImportError:
        pass
    environment = find_environment()
    if environment is not None:
        site.addsitedir(str(site_packages(environment)))
    if str(REPOSITORY) not in sys.path:
        sys.path.append(str(REPOSITORY))
    try:
        import numpy  # noqa: F401

        import phyrogen_core  # noqa: F401
    except ImportError as exc:
        raise ImportError(missing_message(str(exc), extension=(__package__ or "").startswith("bl_ext."))) from None
    share_with_workers()


def missing_message(problem: str, extension: bool) -> str:
    """What to do when PhyRoGen's packages cannot be imported (``problem``: the ImportError's text);
    ``extension``: this runs as a Blender extension, which can bundle them."""
    version = f"{sys.version_info.major}.{sys.version_info.minor}"
    zip_name = "extension zip" if extension else "legacy add-on zip (phyrogen-<version>-legacy.zip)"
    ways = [f"install the PhyRoGen {zip_name} that bundles them (scripts/build_addon.py builds it, for "
            f"Linux x86-64 and Python 3.11; this Blender's Python is {version})"]
    checkout = "a PhyRoGen checkout" if extension else str(REPOSITORY)
    ways.append(f"set {ENVIRONMENT_VARIABLE} to a Python {version} environment where PhyRoGen is installed "
                f"('python{version} -m venv .venv && .venv/bin/pip install -e .' in {checkout}) and start again")
    tried = ", ".join(str(p) for p in candidate_environments())
    return (f"PhyRoGen's Python packages were not found ({problem}). To fix it, " + "; or ".join(ways)
            + f". Environments tried: {tried}.")


WORKER_MODULES = ("phyrogen_core", "solver", "ompl", "numba", "llvmlite", "tqdm", "numpy", "matplotlib", "pybullet",
                  "pybullet_data", "imageio", "imageio_ffmpeg", "PIL")
"""What worker processes (``phyrogen generate``, ``benchmark``, ``manipulate``) import beyond the standard library."""


def make_bundled_binaries_executable() -> None:
    """Give imageio-ffmpeg's bundled ``ffmpeg`` back its executable bit, which unpacking a zip (Blender's
    add-on installer) drops; without it Manipulate's video fails. Only a file that is ours to change."""
    folder = module_search_path("imageio_ffmpeg")
    if folder is None:
        return
    for binary in (Path(folder) / "imageio_ffmpeg" / "binaries").glob("ffmpeg*"):
        try:
            if binary.is_file() and not os.access(binary, os.X_OK) and os.access(binary, os.W_OK):
                binary.chmod(binary.stat().st_mode | 0o111)
        except OSError:
            pass


def module_search_path(name: str) -> str | None:
    """The ``sys.path`` folder from which module ``name`` is imported here, or None when it is not found."""
    try:
        spec = importlib.util.find_spec(name)
    except (ImportError, ValueError):
        return None
    if spec is None or spec.origin is None or not os.path.isabs(spec.origin):
        return None
    origin = Path(spec.origin)
    return str(origin.parent.parent if spec.submodule_search_locations is not None else origin.parent)


def share_with_workers() -> None:
    """Let processes started with :func:`worker_python` import what this process imports.

    Without a virtual environment the workers run this interpreter (Blender's own
    Python), which finds the extension's bundled wheels only because Blender added
    their folder to *this* process's ``sys.path``. Those folders go first on
    ``PYTHONPATH`` in ``os.environ``, which subprocesses inherit. Only such added
    ``site-packages`` folders: never this interpreter's own, nor a checkout that
    is on ``sys.path`` (a folder holding a ``phyrogen`` package would shadow a
    legacy add-on of that name in any Blender started later). The top-level
    ``phyrogen`` package sits beside ``phyrogen_core`` in the bundle.
    """
    if find_environment() is not None:
        return
    own = set(site.getsitepackages())
    folders: list[str] = []
    for name in WORKER_MODULES:
        folder = module_search_path(name)
        if (folder is not None and Path(folder).name == "site-packages" and folder in sys.path
                and folder not in own and folder not in folders):
            folders.append(folder)
    existing = [p for p in os.environ.get("PYTHONPATH", "").split(os.pathsep) if p and p not in folders]
    if folders:
        os.environ["PYTHONPATH"] = os.pathsep.join([*folders, *existing])


def worker_python() -> str:
    """A Python interpreter that can run PhyRoGen's worker processes.

    Inside a Blender binary ``sys.executable`` is a Python without our
    dependencies, so worker processes use the project's environment where there
    is one; otherwise this interpreter, with the extension's bundled wheels on its
    ``PYTHONPATH`` (:func:`share_with_workers`).
    """
    environment = find_environment()
    if environment is not None:
        python = environment / "bin" / "python"
        if python.exists():
            return str(python)
    return sys.executable


BLENDER_VARIABLE = "PHYROGEN_BLENDER"
"""A Blender binary for ``phyrogen render``'s workers (``--blender``): its version writes the ``.blend``."""

_IN_BLENDER = ("import sys; sys.path.insert(0, {repository!r}); "
               "from blender_addon.environment import ensure_project_importable; ensure_project_importable(); "
               "from blender_addon.render_worker import main; sys.exit(main(sys.argv[sys.argv.index('--') + 1:]))")


def render_worker_command() -> list[str]:
    """The command that starts a render worker (:mod:`blender_addon.render_worker`), arguments to follow.

    By default the ``bpy`` module of the project's Python, whose Blender version
    (4.5) writes the ``.blend`` files: Blender 4.5 and later open them, Blender 3.x
    crashes on them. With $PHYROGEN_BLENDER naming a Blender binary, that Blender
    renders and saves, so the files open in that version and later (docs/blender-animation.md).
    """
    blender = os.environ.get(BLENDER_VARIABLE)
    if not blender:
        return [worker_python(), "-m", "blender_addon.render_worker"]
    return [blender, "--background", "--factory-startup", "--python-exit-code", "1",
            "--python-expr", _IN_BLENDER.format(repository=str(REPOSITORY)), "--"]


NUMBA_CACHE_VARIABLE = "NUMBA_CACHE_DIR"


def use_numba_cache(folder: str | Path | None) -> None:
    """Let the workers' numba keep its compiled kernels in ``folder`` (NUMBA_CACHE_DIR, inherited by every
    job), unless the user set one: an installed add-on must not write into its own install folder, and
    without a cache every Generate would compile the collision kernels again (1 to 2 minutes)."""
    if folder is not None:
        os.environ.setdefault(NUMBA_CACHE_VARIABLE, str(folder))


def collision_kernels_cached() -> bool:
    """Whether numba's cache holds the compiled collision kernels (``solver/collision/kernels.py``), so
    that a job starts without compiling them: in NUMBA_CACHE_DIR when set, else beside the source."""
    root = os.environ.get(NUMBA_CACHE_VARIABLE)
    if root:
        return Path(root).is_dir() and next(Path(root).rglob("kernels.*.nbi"), None) is not None
    folder = module_search_path("solver")
    return folder is not None and next((Path(folder) / "solver" / "collision" / "__pycache__").glob(
        "kernels.*.nbi"), None) is not None
