"""pybullet, imported without its ``pybullet build time: ...`` banner.

pybullet's C code prints that line on import straight to file descriptor 2,
where ``sys.stderr`` redirection cannot catch it; a command whose stderr is
meant for messages (one line for bad input) must not start with it. The
package imports this module first, so every module's ``import pybullet``
finds it already loaded.
"""

from __future__ import annotations

import os
import sys


def _import_quietly() -> None:
    if "pybullet" in sys.modules:
        return
    sys.stderr.flush()
    try:
        saved = os.dup(2)
        silent = os.open(os.devnull, os.O_WRONLY)
    except OSError:  # no file descriptor 2 to redirect: nothing would show the banner anyway
        import pybullet  # noqa: F401
        return
    try:
        os.dup2(silent, 2)
        import pybullet  # noqa: F401
    finally:
        os.dup2(saved, 2)
        os.close(saved)
        os.close(silent)


_import_quietly()
