"""The paper's files (results, merges, checkpoints, figures) are written atomically: a write
that fails part way (here a file-size limit in a child process, standing in for a full disk)
leaves the old file byte for byte and no temporary file (the harness: tests/_atomic.py; the
source scan for raw writes of both packages: tests/test_atomic_writes.py)."""

from __future__ import annotations

import contextlib
import errno
import io
from pathlib import Path

import pytest
from _atomic import assert_old_file_whole, run_writers


def _result(seeds):
    from qdensity_paper.results import ExperimentResult

    return ExperimentResult("toy", "quick", {"scale": 1}, list(seeds),
                            [{"v": float(s), "w": 2.0 * s} for s in seeds])


def _save(path: Path) -> None:
    assert _result([0, 1, 2]).save(path.parent) == path


def _merge(path: Path) -> None:
    from qdensity.cli.main import main

    other = path.with_name("b.json")
    if not path.exists():
        _result([0]).save(path.parent)
        path.with_name("toy-quick.json").rename(path)
        _result([1]).save(path.parent)
        path.with_name("toy-quick.json").rename(other)
    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        code = main(["results", "merge", str(path), str(other), "-o", str(path)])
    if code:  # the command reports an error and exits 1: say which one
        raise OSError(errno.EFBIG if "[Errno 27]" in err.getvalue() else None, err.getvalue())


def _checkpoint(path: Path) -> None:
    from qdensity_paper._units import save_unit

    assert save_unit(path.parent, 3, 0, {"epochs": 2}, {"acc": 0.5, "curve": [0.1, 0.2]},
                     "local") == path


def _figure(path: Path) -> None:
    from qdensity_paper._common import curve, plot_curves
    from qdensity_paper.registry import curve_summary
    from qdensity_paper.results import ExperimentResult

    per_seed = [{"a/acc": curve([1, 2], [0.5, 0.6 + s / 10], "epoch", "test accuracy")}
                for s in range(2)]
    result = ExperimentResult("x", "quick", {}, [0, 1], per_seed,
                              curves=curve_summary(per_seed))
    plot_curves(result, [("one", ["a/acc"])], path)


#: name -> (file name, writer(path)): the paper's writers
WRITERS = {
    "ExperimentResult.save": ("toy-quick.json", _save),
    "qdensity results merge -o": ("a.json", _merge),
    "checkpoint (save_unit)": ("seed3-unit0.json", _checkpoint),
    "figure (plot_curves)": ("curves.png", _figure),
}


@pytest.fixture(scope="module")
def size_limited(tmp_path_factory):
    return run_writers("test_paper_atomic_writes", tmp_path_factory.mktemp("paper-writers"))


@pytest.mark.parametrize("name", list(WRITERS))
def test_a_write_past_a_size_limit_leaves_the_old_file_whole(size_limited, name):
    assert_old_file_whole(size_limited[name], name)


@pytest.mark.parametrize("field", ["name", "mode"])
def test_a_results_file_whose_name_is_a_path_is_refused(tmp_path, field):
    import json

    from qdensity_paper.results import ExperimentResult

    doc = _result([0]).to_dict()
    doc[field] = "../../outside"
    path = tmp_path / "evil.json"
    path.write_text(json.dumps(doc))
    with pytest.raises(ValueError, match=f"{field} must be a file name"):
        ExperimentResult.load(path)
    renamed = _result([0])
    setattr(renamed, field, "../outside")  # changed after construction: refused at save
    with pytest.raises(ValueError, match=f"{field} must be a file name"):
        renamed.save(tmp_path / "out")
    assert not (tmp_path / "outside-quick.json").exists() and not (tmp_path / "out").exists()


def test_results_files_refuse_devices_and_fifos(tmp_path):
    import os

    from qdensity_paper.results import ExperimentResult

    fifo = tmp_path / "fifo.json"
    os.mkfifo(fifo)
    for special in ("/dev/zero", fifo):
        with pytest.raises(ValueError, match="must be a regular file"):
            ExperimentResult.load(special)
