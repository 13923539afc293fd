"""The ``qdensity`` command (:mod:`~.main`) and the OpenQASM reference circuits it exports
(:mod:`~.export`)."""

from qdensity.cli.main import BUILDERS, build_circuit, main

__all__ = ["main", "BUILDERS", "build_circuit"]
