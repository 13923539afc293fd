"""The ``moe`` experiment split into (model, seed) units: on two Dask workers with its sweeps
in ``<out>/moe-sweeps.db`` it gives the in-process, in-memory run's metrics bit for bit, and a
rerun resumes the stored studies instead of training again."""

from __future__ import annotations

import shutil

import pytest
from _rows import science as _science

from qdensity_paper import registry

optuna = pytest.importorskip("optuna")
pytest.importorskip("torch")

TINY = {"decompositions": ["butterfly"], "num_qubits": 4, "trials": 2, "epochs": 1,
        "num_train": 60, "num_test": 30}


def test_moe_units_on_two_workers_equal_the_in_process_run_and_resume(client, tmp_path):
    local = registry.run("moe", seeds=[1], config=TINY, progress=False)
    remote = registry.run("moe", seeds=[1], config=TINY, cluster=client, out=tmp_path,
                          plot=False, progress=False)
    assert [_science(r) for r in remote.per_seed] == [_science(r) for r in
                                                      local.to_dict()["per_seed"]]
    workers = remote.per_seed[0]["worker"].split(", ")
    assert set(workers) <= set(client.scheduler_info()["workers"])
    storage = f"sqlite:///{tmp_path / 'moe-sweeps.db'}"
    names = sorted(optuna.get_all_study_names(storage))
    assert [n.split("-")[2] for n in names] == ["butterfly/density", "butterfly/moe",
                                                "butterfly/moe_gelu", "butterfly/pure"]
    for name in names:
        trials = optuna.load_study(study_name=name, storage=storage).trials
        assert [t.state.name for t in trials] == ["COMPLETE", "COMPLETE"]
    # the unit files lost: the units run again, but their sweeps are complete in the storage
    shutil.rmtree(tmp_path / "moe-quick.units")
    again = registry.run("moe", seeds=[1], config=TINY, out=tmp_path, plot=False,
                         progress=False)
    assert [_science(r) for r in again.per_seed] == [_science(r) for r in remote.per_seed]
    for name in names:
        assert len(optuna.load_study(study_name=name, storage=storage).trials) == 2
