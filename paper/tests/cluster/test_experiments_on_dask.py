"""Experiments on Dask: units of (setting, seed), results equal to an in-process run, the
worker named in every per-seed record, checkpoints that a rerun resumes from, a worker lost
mid-unit, bad cluster addresses."""

from __future__ import annotations

import dataclasses
import json
import socket
import time

import numpy as np
import pytest
from _rows import science as _science
from _toy import TOY

from qdensity.cli import main
from qdensity.cluster import parse_cluster
from qdensity_paper import registry


def _oracle(seed: int, model: int) -> float:
    return float(np.random.default_rng([seed, model]).normal())


def test_units_of_a_seed_give_the_whole_seeds_metrics(toys):
    split = registry.run("toy", seeds=[0, 1, 2], progress=False)
    whole = registry.run("toy-whole", seeds=[0, 1, 2], progress=False)
    assert [_science(r) for r in split.per_seed] == [_science(r) for r in whole.per_seed]
    for seed, row in zip([0, 1, 2], split.per_seed, strict=True):
        assert row["worker"] == "in-process"
        for model in (0, 1, 2):
            assert row[f"m{model}/value"] == _oracle(seed, model)  # bit for bit
            draws = np.random.default_rng([seed, model])
            draws.normal()
            assert row[f"m{model}/draws"] == draws.normal(size=3).tolist()
    assert split.summary["m1/value"]["mean"] == pytest.approx(np.mean([_oracle(s, 1)
                                                                        for s in range(3)]))


def test_two_workers_give_the_in_process_result_and_name_themselves(toys, client):
    local = registry.run("toy", seeds=[0, 1, 2], progress=False)
    remote = registry.run("toy", seeds=[0, 1, 2], cluster=client, progress=False)
    assert [_science(r) for r in remote.per_seed] == [_science(r) for r in local.per_seed]
    assert _science(remote.summary) == _science(local.summary)
    assert remote.curves == local.curves
    addresses = set(client.scheduler_info()["workers"])
    used = {w for r in remote.per_seed for w in r["worker"].split(", ")}
    assert used <= addresses and all(w.startswith("tcp://127.0.0.1:") for w in used)


def test_a_worker_lost_mid_unit_is_rerun_with_the_same_result(toys, client, tmp_path):
    marker = tmp_path / "died"
    config = {"die_once": str(marker)}
    remote = registry.run("toy", seeds=[0, 1, 2], config=config, cluster=client,
                          progress=False)
    assert marker.exists()  # the unit of (model 0, seed 1) killed its worker once
    local = registry.run("toy", seeds=[0, 1, 2], config=config, progress=False)  # no death now
    assert [_science(r) for r in remote.per_seed] == [_science(r) for r in local.per_seed]
    for seed, row in zip([0, 1, 2], remote.per_seed, strict=True):
        assert [row[f"m{m}/value"] for m in range(3)] == [_oracle(seed, m) for m in range(3)]


def test_finished_units_are_written_and_a_rerun_resumes(toys, tmp_path, monkeypatch, client):
    first = registry.run("toy", seeds=[0, 1], out=tmp_path, cluster=client, progress=False)
    units = sorted((tmp_path / "toy-quick.units").glob("*/seed*-unit*.json"))
    assert len(units) == 6
    record = json.loads(units[0].read_text())
    assert record["worker"].startswith("tcp://127.0.0.1:")
    # nothing runs again: a run_seed that fails would be noticed
    calls = []

    def counting(config, seed, progress):
        calls.append((seed, config["models"]))
        return TOY.run_seed(config, seed, progress)

    table = {"toy": dataclasses.replace(TOY, run_seed=counting)}
    monkeypatch.setattr(registry, "get_experiment", lambda name: table[name])
    again = registry.run("toy", seeds=[0, 1], out=tmp_path, progress=False)
    assert calls == []
    assert again.per_seed == first.per_seed  # the workers recorded, the seconds kept
    units[0].unlink()  # seed 0, model 0 lost: only that unit runs again
    registry.run("toy", seeds=[0, 1], out=tmp_path, progress=False)
    assert calls == [(0, [0])]
    # other settings are another run: nothing of the first is reused
    registry.run("toy", seeds=[0], out=tmp_path, config={"sleep": 0.001}, progress=False)
    assert len(calls) == 4
    saved = json.loads((tmp_path / "toy-quick.json").read_text())
    assert all("worker" in row for row in saved["per_seed"])


def test_cluster_addresses():
    assert parse_cluster("local") == ("local", None)
    assert parse_cluster("local:3") == ("local", 3)
    assert parse_cluster("tcp://127.0.0.1:8786") == ("tcp", "tcp://127.0.0.1:8786")
    for bad in ("locale", "local:0", "local:x", "udp://h:1", "tcp://nohost", "tcp://h:0", ""):
        with pytest.raises(ValueError, match="allowed: 'local'.*'local:N'.*tcp://HOST:PORT"):
            parse_cluster(bad)
    with pytest.raises(TypeError, match="cluster must be a str"):
        parse_cluster(4)


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def test_unreachable_scheduler_is_a_clear_error_within_ten_seconds(toys, capsys):
    address = f"tcp://127.0.0.1:{_free_port()}"
    t0 = time.monotonic()
    with pytest.raises(OSError, match=f"cannot reach a dask scheduler at '{address}'"):
        registry.run("toy", seeds=[0, 1], cluster=address, progress=False)
    assert time.monotonic() - t0 < 15
    assert main(["experiment", "toy", "--cluster", address, "--seeds", "2"]) == 2
    err = capsys.readouterr().err
    assert address in err and "Traceback" not in err and len(err.strip().splitlines()) == 1


def test_bad_cluster_arguments(toys, capsys):
    with pytest.raises(ValueError, match="unknown cluster address 'slurm://x'; allowed"):
        registry.run("toy", cluster="slurm://x", progress=False)
    with pytest.raises(ValueError, match="give jobs .* or cluster .*, not both"):
        registry.run("toy", jobs=2, cluster="tcp://127.0.0.1:1", progress=False)
    with pytest.raises(ValueError, match="retries must be an int >= 0"):
        registry.run("toy", retries=-1, progress=False)
    assert main(["experiment", "toy", "--cluster", "mpi://x"]) == 2
    assert "allowed: 'local'" in capsys.readouterr().err


def test_the_command_on_two_local_workers_equals_the_in_process_run(tmp_path, capsys):
    """A real experiment through ``--cluster local:2`` (an embedded LocalCluster)."""
    tiny = {"num_qubits": 3, "num_subunitaries": 2, "train_size": 8, "test_size": 4,
            "student_epochs": 1, "alpha_epochs": 1, "batch_size": 4}
    sets = [a for k, v in tiny.items() for a in ("--set", f"{k}={v}")]
    assert main(["experiment", "mixing-lemma", "--cluster", "local:2", "--seeds", "2",
                 "--out", str(tmp_path), "--no-plot", "--json", *sets]) == 0
    remote = json.loads(capsys.readouterr().out)
    local = registry.run("mixing-lemma", seeds=2, config=tiny, progress=False)
    assert [_science(r) for r in remote["per_seed"]] == [_science(r) for r in local.to_dict()[
        "per_seed"]]
    assert all(r["worker"].startswith("tcp://127.0.0.1:") for r in remote["per_seed"])
    assert {r["worker"] for r in local.per_seed} == {"in-process"}


def test_orthoqnn_depth_units_train_what_the_whole_seed_trains():
    """Split into the pure model and one unit per depth, a seed gives what ``run_seed`` gives
    for the whole seed in one call (the units draw the seeds of the models before them)."""
    from qdensity_paper.orthoqnn_depth import EXPERIMENT

    tiny = {**EXPERIMENT.quick, "num_qubits": 4, "depths": [1, 3], "pretrain_epochs": 1,
            "epochs": 1, "train_size": 40, "test_size": 20}
    whole = EXPERIMENT.run_seed(dict(tiny), 2, False)
    split = registry.run("orthoqnn-depth", seeds=[2], config=tiny, progress=False).per_seed[0]
    assert len(EXPERIMENT.units(tiny)) == 3
    assert _science(split) == _science(json.loads(json.dumps(whole)))
