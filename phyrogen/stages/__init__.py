"""The stages: each job of PhyRoGen is one function ``run(request) -> result`` of its module here, over the
frozen, typed, versioned records of :mod:`phyrogen_core.stage_records`.

The command line's modules (``phyrogen.commands``) turn arguments into a request and a result into text
or ``--json``; the Python API (``phyrogen.run``) takes a request and returns the result. A stage checks
its whole request before any work: bad input raises a :class:`ValueError` (or :class:`FileNotFoundError`)
of one line naming the value or the file, which the command line answers with exit code 2.
Some take optional keyword callbacks that report work as it goes (a row per puzzle, the puzzles running),
for a progress display; the result is the same without them.
"""

from __future__ import annotations

import importlib

STAGES = {"check": "CheckRequest", "generate": "GenerateRequest", "certify": "CertifyRequest",
          "replan": "ReplanRequest", "export": "ExportRequest", "import_urdf": "ImportRequest",
          "benchmark": "BenchmarkRequest", "manipulate": "ManipulateRequest", "audit": "AuditRequest",
          "render": "RenderRequest", "dataset": "DatasetRequest"}
"""Each stage's module (``phyrogen.stages.<name>``) and its request record's name. Each but ``certify`` (Python
only) is also a command of ``phyrogen`` (``import_urdf``: ``phyrogen import``)."""


def run(request, **callbacks):
    """The result of the stage that ``request`` (a request record) asks for."""
    for name, request_type in STAGES.items():
        if type(request).__name__ == request_type and type(request).__module__.startswith(
                "phyrogen_core.stage_records."):
            return importlib.import_module(f"phyrogen.stages.{name}").run(request, **callbacks)
    raise TypeError(f"{type(request).__name__} is no stage's request (the requests: {', '.join(STAGES.values())})")
