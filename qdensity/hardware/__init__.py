"""The device side of the spine: hardware targets (named, device snapshots, snapshot files),
noise models, transpilation (pass managers, the RBS-native gate set), the choice of Aer's
simulation method, transpiled resource reports, a provider's runtime client, and readout
mitigation with Hamming-weight post-selection.

``execution`` (plans, engines, schedulers) builds on this package; nothing here imports it.
"""

from qdensity.hardware.resources import ResourceReport, compare_reports, resource_report
from qdensity.hardware.snapshot_files import load_snapshot, save_snapshot
from qdensity.hardware.targets import HardwareTarget, get_target, known_targets

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
