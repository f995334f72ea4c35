"""The commands of ``phyrogen``, one module each: ``add_parser(sub)`` declares its arguments, ``run(args)``
turns them into the request of its stage (:mod:`phyrogen.stages`), runs it, and turns the result into text
(or, with ``--json``, sets ``args.json_result`` to the result record, printed as its own JSON). ``list``
only prints the registry, and ``benchmark --report`` and ``dataset --stats`` read what a stage wrote.
What several share lives beside the package: ``phyrogen.options`` (option types, limits, seed and generator
lists), ``phyrogen.ray_options``, ``phyrogen.difficulty_options``, ``phyrogen.progress``,
``phyrogen.json_output``; ``phyrogen.signals`` and ``phyrogen.cli`` (the entry point) run them."""

COMMANDS = ("list", "generate", "dataset", "check", "replan", "export", "import_", "benchmark", "manipulate",
            "audit", "render")
"""In the order ``phyrogen --help`` lists them; ``import_`` is ``phyrogen import`` (``import`` is Python's)."""
