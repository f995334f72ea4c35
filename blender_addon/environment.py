"""Finding PhyRoGen's Python environment from inside a Blender binary.

A Blender binary embeds its own Python without numpy, OMPL or our packages;
the project's virtual environment supplies them. Its site-packages are added
with :func:`site.addsitedir` so that ``.pth`` files (the editable install of
PhyRoGen itself) are honoured. No bpy here: entry scripts call this first.
"""

from __future__ import annotations

import os
import site
import sys
from pathlib import Path

REPOSITORY = Path(__file__).resolve().parent.parent
ENVIRONMENT_VARIABLE = "PHYROGEN_VENV"


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
    try:
        import numpy  # noqa: F401

        import phyrogen_core  # noqa: F401
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
        tried = ", ".join(str(p) for p in candidate_environments())
        version = f"{sys.version_info.major}.{sys.version_info.minor}"
        raise ImportError(
            f"PhyRoGen's Python environment was not found ({exc}); tried {tried}. Create it with "
            f"'python{version} -m venv .venv && .venv/bin/pip install -e .' in {REPOSITORY}, or set "
            f"{ENVIRONMENT_VARIABLE} to a Python {version} environment where PhyRoGen is installed"
        ) from None


def worker_python() -> str:
    """A Python interpreter that can run PhyRoGen's worker processes.

    Inside a Blender binary ``sys.executable`` is a Python without our
    dependencies, so worker processes use the project's environment instead.
    """
    environment = find_environment()
    if environment is not None:
        python = environment / "bin" / "python"
        if python.exists():
            return str(python)
    return sys.executable
