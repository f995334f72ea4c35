"""The progress bar of a command, on stderr, and what it says of the work running."""

from __future__ import annotations

import sys
import time


def progress_bar(total: int, quiet: bool):
    """A progress bar on stderr (none when ``quiet``), also for a single puzzle: it may take long."""
    from tqdm import tqdm

    return tqdm(total=total, unit="puzzle", disable=quiet, file=sys.stderr)


def show_running(progress, names: list[str]) -> None:
    """Name the first three of the puzzles running (and how many more) after the bar."""
    if progress.disable:
        return
    text = "running " + ", ".join(names[:3]) + (f" and {len(names) - 3} more" if len(names) > 3 else "")
    # Once a second at least, so that the elapsed time moves while a long puzzle runs.
    since = time.time() - progress.last_print_t
    if since >= 1.0 or (text != progress.postfix and since >= progress.mininterval):
        progress.set_postfix_str(text)
