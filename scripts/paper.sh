#!/usr/bin/env bash
# The main job: the paper's 24 puzzles (six generators x seeds 1-4), certified,
# exported, rendered, with a gallery page at <out>/index.html.
# It needs the base packages and the Blender extra only (the tests and the other
# scripts install the rest). With PHYROGEN_STAGE_TIMES=1 it says on stderr when
# each stage ends (benchmarks/main_job_time.py times the job from a fresh clone).
export PHYROGEN_EXTRAS="${PHYROGEN_EXTRAS-}"
source "$(dirname "${BASH_SOURCE[0]}")/env.sh"
stage_done() {
  if [ -n "${PHYROGEN_STAGE_TIMES:-}" ]; then echo "paper.sh: stage $1 done at $(date +%s.%N)" >&2; fi
}
apt_install libgl1 libx11-6 libxrender1 libxfixes3 libxi6 libxkbcommon0 libsm6 libxext6 \
  libegl1 libegl-mesa0 libgl1-mesa-dri
if ! "$VENV/bin/python" -c 'import importlib.util as u, sys; sys.exit(not (u.find_spec("bpy") and u.find_spec("PIL")))'
then
  # A new environment: numba compiles the generator's kernels into its cache (one core, about
  # 40 s) while pip unpacks Blender (800 MB) on the other, instead of one after the other.
  "$VENV/bin/python" -c "import solver.pipelines._server_warmup" &
  compiling=$!
  "$VENV/bin/python" -m pip install --quiet -e "$ROOT[blender]"
  wait "$compiling"
fi
stage_done install
OUT="${1:-output}"
"$VENV/bin/phyrogen" generate --generator all --seeds 1-4 --out "$OUT"
stage_done generation
"$VENV/bin/phyrogen" render --out "$OUT" --workers 2
stage_done render
