"""The OMPL-free part of the solver imports without OMPL."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def test_problem_actions_and_pool_modules_do_not_import_ompl():
    code = "import sys, solver.planning.problem, solver.parallel.pool; assert 'ompl' not in sys.modules"
    result = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True)
    assert result.returncode == 0, result.stderr
