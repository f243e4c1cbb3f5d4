"""Type stubs for the compiled engine ``lfd._hmmseg`` (checked by ``mypy.stubtest``)."""

__version__: str
