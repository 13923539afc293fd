"""The ``lcu-vs-single`` sweep split into (model, seed) units: on two Dask workers with its
studies in ``<out>/lcu-vs-single-sweeps.db`` it gives the in-process, in-memory run's metrics
bit for bit (each trial draws from its own stream, wherever it runs)."""

from __future__ import annotations

import pytest
from _rows import science as _science

from qdensity_paper import registry

optuna = pytest.importorskip("optuna")

TINY = {"num_qubits": 3, "train_size": 30, "test_size": 30, "pretrain_epochs": 1,
        "lcu_epochs": 1, "batch_size": 10, "sampled_points": 0, "trials": 2}


def test_lcu_units_on_two_workers_equal_the_in_process_run(client, tmp_path):
    local = registry.run("lcu-vs-single", seeds=[2], config=TINY, progress=False)
    remote = registry.run("lcu-vs-single", seeds=[2], config=TINY, cluster=client, out=tmp_path,
                          plot=False, progress=False)
    assert [_science(r) for r in remote.per_seed] == [_science(r) for r in
                                                      local.to_dict()["per_seed"]]
    assert set(remote.per_seed[0]["worker"].split(", ")) <= set(
        client.scheduler_info()["workers"])
    units = sorted(p.name for p in (tmp_path / "lcu-vs-single-quick.units").glob("*/*.json"))
    assert units == ["seed2-unit0.json", "seed2-unit1.json"]  # one unit per model
    storage = f"sqlite:///{tmp_path / 'lcu-vs-single-sweeps.db'}"
    for name in optuna.get_all_study_names(storage):
        trials = optuna.load_study(study_name=name, storage=storage).trials
        assert [t.state.name for t in trials] == ["COMPLETE", "COMPLETE"]
