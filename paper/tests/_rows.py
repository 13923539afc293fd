"""What experiment tests compare between runs: a per-seed row without what differs between
machines, and a rerun that must resume its sweeps from their optuna storage."""

from __future__ import annotations

import shutil
from pathlib import Path


def science(row: dict) -> dict:
    """A per-seed row without what differs between machines (its time and its worker)."""
    return {k: v for k, v in row.items() if k not in ("seconds", "worker")}


def assert_rerun_resumes(run, name: str, seed: int, config: dict, out: Path, storage: str,
                         studies: list[str], row: dict, trials: int, **kwargs) -> None:
    """Delete the unit files under ``out`` and run again: every study in ``storage`` still
    holds ``trials`` trials (resumed, none trained again) and the per-seed row is ``row``."""
    import optuna

    for d in Path(out).glob("*.units"):
        shutil.rmtree(d)
    again = run(name, seeds=[seed], config=config, out=out, progress=False, **kwargs)
    for study in studies:
        assert len(optuna.load_study(study_name=study, storage=storage).trials) == trials
    assert science(again.per_seed[0]) == science(row)
