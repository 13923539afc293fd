"""Results and unit files that runs share: nothing lost, nothing untrusted used.

A toy experiment (one unit per model, seeded draws that depend only on (model, seed): the
oracle) runs in process. Runs with other seeds or settings into one folder both keep their
results, each told which file holds them; a results file is replaced atomically (a write that
fails with a full disk leaves the old one); a unit file that is corrupted, binary, UTF-16,
edited or missing a field is run again with a warning naming it.
"""

from __future__ import annotations

import errno
import json
import threading

import numpy as np
import pytest

import qdensity.io
from qdensity_paper import registry
from qdensity_paper.merge import merge_results
from qdensity_paper.registry import Experiment
from qdensity_paper.results import ExperimentResult


def _oracle(seed: int, model: int) -> float:
    return float(np.random.default_rng([seed, model]).normal())


def _seed(config, seed, progress):
    return {f"m{m}/value": _oracle(seed, m) for m in config["models"]}


TOY = Experiment(name="toy", title="a toy", paper="none", quick={"models": [0, 1], "scale": 1},
                 full={"models": [0, 1], "scale": 1}, run_seed=_seed,
                 plot=lambda result, directory: [], seeds={"quick": 2, "full": 2},
                 units=lambda config: [{**config, "models": [m]} for m in config["models"]])


@pytest.fixture
def toy(monkeypatch):
    calls = []

    def counting(config, seed, progress):
        calls.append((seed, tuple(config["models"])))
        return _seed(config, seed, progress)

    import dataclasses

    exp = dataclasses.replace(TOY, run_seed=counting)
    monkeypatch.setitem(registry.EXPERIMENTS, "toy", "toy")
    real = registry.get_experiment
    monkeypatch.setattr(registry, "get_experiment",
                        lambda name: exp if name == "toy" else real(name))
    return calls


def _values(path) -> dict[int, float]:
    data = json.loads(path.read_text())
    return {s: row["m0/value"] for s, row in zip(data["seeds"], data["per_seed"], strict=True)}


def test_runs_with_other_seeds_merge_into_one_file(toy, tmp_path):
    a = registry.run("toy", seeds=[0, 1], out=tmp_path, progress=False)
    b = registry.run("toy", seeds=[2, 3], out=tmp_path, progress=False)
    assert a.saved_to == b.saved_to == tmp_path / "toy-quick.json"
    assert _values(b.saved_to) == {s: _oracle(s, 0) for s in range(4)}
    data = json.loads(b.saved_to.read_text())
    assert data["summary"]["m1/value"]["mean"] == pytest.approx(
        np.mean([_oracle(s, 1) for s in range(4)]), rel=1e-12)
    assert data["summary"]["m1/value"]["n"] == 4


def test_runs_with_other_settings_keep_their_own_files(toy, tmp_path, capsys):
    from qdensity.cli import main

    assert main(["experiment", "toy", "--seeds", "2", "--out", str(tmp_path)]) == 0
    first = capsys.readouterr().out
    assert main(["experiment", "toy", "--seeds", "2", "--set", "scale=2",
                 "--out", str(tmp_path)]) == 0
    second = capsys.readouterr().out
    printed = [line.split("results: ")[1].strip() for text in (first, second)
               for line in text.splitlines() if line.startswith("results: ")]
    assert printed[0] == str(tmp_path / "toy-quick.json") and printed[1] != printed[0]
    for path in printed:
        data = json.loads(open(path).read())
        assert data["seeds"] == [0, 1]
    assert json.loads(open(printed[1]).read())["config"]["scale"] == 2
    assert json.loads(open(printed[0]).read())["config"]["scale"] == 1


def _result(seeds, scale=1) -> ExperimentResult:
    return ExperimentResult("toy", "quick", {"scale": scale}, list(seeds),
                            [{"v": float(s)} for s in seeds])


def test_concurrent_saves_into_one_folder_lose_nothing(tmp_path):
    threads = [threading.Thread(target=_result([s]).save, args=(tmp_path,)) for s in range(8)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    data = json.loads((tmp_path / "toy-quick.json").read_text())
    assert data["seeds"] == list(range(8))
    assert data["summary"]["v"]["mean"] == pytest.approx(3.5)


def test_a_full_disk_leaves_the_old_file_whole(tmp_path, monkeypatch):
    path = _result([0, 1]).save(tmp_path)
    before = path.read_bytes()
    real = open

    class Full:
        def __init__(self, handle):
            self.handle = handle

        def __enter__(self):
            return self

        def __exit__(self, *exc):
            self.handle.close()

        def write(self, text):
            self.handle.write(text[: len(text) // 2])
            raise OSError(errno.ENOSPC, "No space left on device")

    # the results file is written through qdensity.io's open (a temporary file, then a rename)
    monkeypatch.setattr(qdensity.io, "open", lambda *a, **k: Full(real(*a, **k)), raising=False)
    with pytest.raises(OSError) as info:
        _result([2]).save(tmp_path)
    assert info.value.errno == errno.ENOSPC
    assert path.read_bytes() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == [".toy-quick.json.lock",
                                                          "toy-quick.json"]


@pytest.mark.parametrize("edit", ["binary", "utf16", "metric", "truncated", "metrics-missing",
                                  "metrics-null", "metrics-list", "worker-missing",
                                  "worker-null", "worker-list", "not-a-dict"])
def test_an_untrusted_unit_runs_again_with_a_warning(toy, tmp_path, edit):
    registry.run("toy", seeds=[0], out=tmp_path, progress=False)
    assert len(toy) == 2
    unit = sorted((tmp_path / "toy-quick.units").glob("*/seed0-unit0.json"))[0]
    record = json.loads(unit.read_text())
    if edit == "binary":
        unit.write_bytes(b"\x00\xff\xfe\x80garbage")
    elif edit == "utf16":
        unit.write_bytes(json.dumps(record).encode("utf-16"))
    elif edit == "metric":
        record["metrics"]["m0/value"] = 99.0  # edited by hand, checksum kept
        unit.write_text(json.dumps(record))
    elif edit == "truncated":
        unit.write_text(json.dumps(record)[:40])
    elif edit == "not-a-dict":
        unit.write_text("[1, 2]")
    else:
        field, how = edit.split("-")
        if how == "missing":
            del record[field]
        else:
            record[field] = None if how == "null" else [1, 2]
        unit.write_text(json.dumps(record))
    with pytest.warns(UserWarning, match="seed0-unit0.json"):
        again = registry.run("toy", seeds=[0], out=tmp_path, progress=False)
    assert toy[2:] == [(0, (0,))]  # only the untrusted unit ran again
    assert again.per_seed[0]["m0/value"] == _oracle(0, 0)
    assert json.loads(unit.read_text())["metrics"]["m0/value"] == _oracle(0, 0)
    registry.run("toy", seeds=[0], out=tmp_path, progress=False)  # rewritten: trusted now
    assert len(toy) == 3


def test_results_file_with_an_edited_summary_is_shown_recomputed(tmp_path):
    path = _result([0, 1, 2]).save(tmp_path)
    data = json.loads(path.read_text())
    data["summary"]["v"]["mean"] = 42.0
    path.write_text(json.dumps(data))
    with pytest.warns(UserWarning, match="toy-quick.json.*summary"):
        back = ExperimentResult.load(path)
    assert back.summary["v"]["mean"] == pytest.approx(1.0)


@pytest.mark.parametrize("seeds, error", [([-1, 0], ValueError), ([0.5, 1], ValueError),
                                          (["0", 1], ValueError), ([True, 1], ValueError),
                                          ([1, 1], ValueError), ("01", TypeError)])
def test_results_file_with_bad_seeds_is_refused(tmp_path, seeds, error):
    path = _result([0, 1]).save(tmp_path)
    data = json.loads(path.read_text())
    data["seeds"] = seeds
    path.write_text(json.dumps(data))
    with pytest.raises(error, match="toy-quick.json.*seeds"):
        ExperimentResult.load(path)


@pytest.mark.parametrize("field, value", [("per_seed", {"0": 1}), ("per_seed", [1, 2]),
                                          ("config", [1]), ("name", 3), ("figures", [1])])
def test_results_file_with_wrong_types_is_refused(tmp_path, field, value):
    path = _result([0, 1]).save(tmp_path)
    data = json.loads(path.read_text())
    data[field] = value
    path.write_text(json.dumps(data))
    with pytest.raises((TypeError, ValueError), match=f"toy-quick.json.*{field}"):
        ExperimentResult.load(path)


def test_merge_refuses_bad_seeds_and_accepts_runs_differing_in_worker():
    with pytest.raises(ValueError, match="seeds must be non-negative ints, got -1"):
        ExperimentResult("toy", "quick", {}, [-1], [{"v": 1.0}])
    with pytest.raises(ValueError, match="got 0.5"):
        ExperimentResult("toy", "quick", {}, [0.5], [{"v": 1.0}])
    bent = _result([0])
    bent.seeds = [-1]
    with pytest.raises(ValueError, match=r"results\[1\].*-1"):
        merge_results([_result([1]), bent])
    a = ExperimentResult("toy", "quick", {}, [0, 1], [{"v": 1.0, "worker": "tcp://a:1"},
                                                      {"v": 2.0, "worker": "tcp://a:1"}])
    b = ExperimentResult("toy", "quick", {}, [0, 1], [{"v": 1.0, "worker": "tcp://b:2"},
                                                      {"v": 2.0, "worker": "tcp://b:2"}])
    merged = merge_results([a, b])
    assert merged.seeds == [0, 1] and merged.summary["v"]["mean"] == pytest.approx(1.5)


def test_deeply_nested_results_file_is_a_clear_error(tmp_path):
    path = tmp_path / "deep.json"
    path.write_text("[" * 200_000 + "]" * 200_000)
    with pytest.raises(ValueError, match="deep.json.*nested deeper"):
        ExperimentResult.load(path)
    _result([0]).save(tmp_path)  # a folder whose results file is unreadable still takes runs
    (tmp_path / "toy-quick.json").write_text("[" * 200_000)
    path = _result([1]).save(tmp_path)
    assert path.name.startswith("toy-quick-") and json.loads(path.read_text())["seeds"] == [1]
