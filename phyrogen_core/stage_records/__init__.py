"""The stages' requests and results: frozen, typed, versioned records, each with one strict reader.

A stage (``phyrogen.stages``) is one function ``run(request) -> result``. Its request and result
records live here, in the core, so that every face reads them with the same types: the Python API
and the command line build requests, the command line's ``--json`` writes a result's
:meth:`~base.StageResult.to_json`, and the Blender panel (which may not import the top layer) reads
that text back with :meth:`~base.StageResult.from_json`. The machinery is in :mod:`.base`; one
module per stage holds its two records.
"""
