"""Generate two small puzzles from a plain script, with no ``if __name__ == "__main__":`` guard.

    python docs/examples/generate_from_script.py              # writes under output/examples
    python docs/examples/generate_from_script.py OUT          # writes under OUT

Each puzzle is generated in a fresh worker process (OMPL's random generator
can be seeded only once per process); the workers never run this file again,
so the calls below may sit at the top level. Prints one line per puzzle: its
folder and the number of actions in its certificate (one object moved per
action), then checks each certificate again at 2 mm.
"""

import json
import sys

import phyrogen

out = sys.argv[1] if len(sys.argv) > 1 else "output/examples"
for generator, seed, params in [("simple_slider", 1, {"n_objects": 2}), ("grid_world", 2, {"n_objects": 3})]:
    folder = phyrogen.generate_into(out, generator, seed, **params)
    actions = json.loads((folder / "puzzle.json").read_text())["certificate_actions"]
    problems = phyrogen.check(folder)  # empty: the certificate holds
    print(f"{folder}: {actions} certificate actions, {'; '.join(problems) or 'valid'}")
