#!/usr/bin/env bash
# The main job: the paper's 24 puzzles (six generators x seeds 1-4), certified,
# exported, rendered, with a gallery page at <out>/index.html.
source "$(dirname "${BASH_SOURCE[0]}")/env.sh"
apt_install libgl1 libx11-6 libxrender1 libxfixes3 libxi6 libxkbcommon0 libsm6 libxext6 \
  libegl1 libegl-mesa0 libgl1-mesa-dri
OUT="${1:-output}"
"$VENV/bin/phyrogen" generate --generator all --seeds 1-4 --out "$OUT"
"$VENV/bin/phyrogen" render --out "$OUT" --workers 2
