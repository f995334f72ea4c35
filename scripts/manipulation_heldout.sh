#!/usr/bin/env bash
# The held-out manipulation run (docs/manipulation/README.md#held-out-run): six generators x ten
# seeds that no test uses, generated and executed at the physical scale; the table goes to
# <out>/heldout.md. Move N Times and Simple Slider tie their size to the seed, so their sizes are
# set to the paper's range (n = 1-4, 2-5 sliders) in turn.
#   bash scripts/manipulation_heldout.sh [OUT] [FIRST_SEED]   (seeds FIRST_SEED..FIRST_SEED+9)
# Each puzzle runs the default solution source: a short LA-RRT benchmark's best path, else the
# certificate.
source "$(dirname "${BASH_SOURCE[0]}")/env.sh"
OUT="${1:-output/heldout}"
FIRST="${2:-86101}"
LAST=$((FIRST + 9))
for generator in continuous_space grid_world lockbox_random rooms; do
  "$VENV/bin/phyrogen" generate --generator "$generator" --seeds "$FIRST-$LAST" --out "$OUT/puzzles" --quiet
done
for seed in $(seq "$FIRST" "$LAST"); do
  size=$(( (seed - FIRST) % 4 + 1 ))
  "$VENV/bin/phyrogen" generate --generator move_n_times --seeds "$seed" --set "n=$size" --out "$OUT/puzzles" --quiet
  "$VENV/bin/phyrogen" generate --generator simple_slider --seeds "$seed" --set "n_objects=$((size + 1))" \
    --out "$OUT/puzzles" --quiet
done
"$VENV/bin/phyrogen" manipulate "$OUT/puzzles" --out "$OUT/manipulation" --no-video --quiet --table "$OUT/heldout.md"
