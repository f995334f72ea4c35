#!/usr/bin/env bash
# The audit behind docs/audit-results.md: the paper's 24 puzzles and 120 held-out ones
# (seeds 500-519 of every generator, which no test uses), generated and audited.
# Where the paper ties the size to the seed, sizes are set: Simple Slider 3 and 5 sliders,
# Move N Times n = 3 and 4 (ten seeds each).
source "$(dirname "${BASH_SOURCE[0]}")/env.sh"
OUT="${1:-output/audit-set}"
P="$VENV/bin/phyrogen"
"$P" generate --generator all --seeds 1-4 --out "$OUT/paper" --quiet
for g in continuous_space grid_world lockbox_random rooms; do
  "$P" generate --generator "$g" --seeds 500-519 --out "$OUT/heldout" --quiet
done
"$P" generate --generator simple_slider --seeds 500-509 --set n_objects=3 --out "$OUT/heldout" --quiet
"$P" generate --generator simple_slider --seeds 510-519 --set n_objects=5 --out "$OUT/heldout" --quiet
"$P" generate --generator move_n_times --seeds 500-509 --set n=3 --out "$OUT/heldout" --quiet
"$P" generate --generator move_n_times --seeds 510-519 --set n=4 --out "$OUT/heldout" --quiet
status=0
"$P" audit "$OUT/paper" --out "$OUT/audit-paper" --quiet || status=$?
"$P" audit "$OUT/heldout" --out "$OUT/audit-heldout" --quiet || status=$?
exit $status
