"""The device side of the spine: hardware targets (named, device snapshots, snapshot files),
noise models, transpilation (pass managers, the RBS-native gate set), the choice of Aer's
simulation method, transpiled resource reports, a provider's runtime client, and readout
mitigation with Hamming-weight post-selection.

``execution`` (plans, engines, schedulers) builds on this package; nothing here imports it.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from qdensity._lazy import lazy_exports

__all__ = [
    "HardwareTarget",
    "get_target",
    "known_targets",
    "ResourceReport",
    "resource_report",
    "compare_reports",
    "save_snapshot",
    "load_snapshot",
]

#: public name -> the module that defines it, imported on first use (PEP 562)
_EXPORTS: dict[str, str] = {
    "ResourceReport": "qdensity.hardware.resources",
    "compare_reports": "qdensity.hardware.resources",
    "resource_report": "qdensity.hardware.resources",
    "load_snapshot": "qdensity.hardware.snapshot_files",
    "save_snapshot": "qdensity.hardware.snapshot_files",
    "HardwareTarget": "qdensity.hardware.targets",
    "get_target": "qdensity.hardware.targets",
    "known_targets": "qdensity.hardware.targets",
}

if TYPE_CHECKING:  # static analysers and IDEs see the eager imports
    from qdensity.hardware.resources import ResourceReport, compare_reports, resource_report
    from qdensity.hardware.snapshot_files import load_snapshot, save_snapshot
    from qdensity.hardware.targets import HardwareTarget, get_target, known_targets


if not TYPE_CHECKING:  # type checkers see the imports above, not a catch-all lookup
    __getattr__, __dir__ = lazy_exports(__name__, _EXPORTS, __all__)
