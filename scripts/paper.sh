#!/usr/bin/env bash
# The main job: the paper's 24 puzzles (six generators x seeds 1-4), certified, exported and rendered.
source "$(dirname "${BASH_SOURCE[0]}")/env.sh"
OUT="${1:-output}"
"$VENV/bin/phyrogen" generate --generator all --seeds 1-4 --out "$OUT"
