#!/usr/bin/env bash
# The test suite, slow end-to-end tests included, on every core (pytest-xdist: -n auto, each
# test file on one worker, so that a file's module fixtures are built once and its tests
# that share something run one after another). Extra arguments go to pytest, after ours:
#   scripts/test.sh -m "not slow"           the fast subset
#   scripts/test.sh -n 0                    serially, in this process (e.g. to use --pdb)
#   scripts/test.sh tests/test_cli.py -x    one file, stopping at the first failure
# Tests wait for events rather than for the clock, with backstops of minutes against hangs
# only (tests/waiting.py): a busy machine makes the run slower, not red.
source "$(dirname "${BASH_SOURCE[0]}")/env.sh"
apt_install libgl1 libx11-6 libxrender1 libxfixes3 libxi6 libxkbcommon0 libsm6 libxext6 \
  blender xvfb xauth xdotool chromium \
  libegl1 libegl-mesa0 libgl1-mesa-dri
cd "$ROOT"
"$VENV/bin/ruff" check .
exec "$VENV/bin/python" -m pytest -n auto --dist loadfile --durations=15 "$@"
