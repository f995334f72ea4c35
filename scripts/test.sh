#!/usr/bin/env bash
# The test suite, slow end-to-end tests included. Extra arguments go to pytest
# (e.g. scripts/test.sh -m "not slow" for the fast subset).
source "$(dirname "${BASH_SOURCE[0]}")/env.sh"
apt_install libgl1 libx11-6 libxrender1 libxfixes3 libxi6 libxkbcommon0 libsm6 libxext6 \
  blender xvfb xauth xdotool chromium \
  libegl1 libegl-mesa0 libgl1-mesa-dri
cd "$ROOT"
"$VENV/bin/ruff" check .
exec "$VENV/bin/python" -m pytest --durations=15 "$@"
