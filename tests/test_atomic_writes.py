"""Every file the library writes is written atomically (``qdensity.io``).

Oracles: bytes read back from disk (the old file byte for byte after a failed write, the new
content after a successful one), the folder's listing (no temporary file left), ``os.stat``
modes against a file ``open`` creates, and the order of the ``fsync`` and ``os.replace`` calls.
A file-size limit (``RLIMIT_FSIZE`` with ``SIGXFSZ`` ignored, in a child process) stands in
for a full disk: a write past it raises ``OSError`` (``EFBIG``) as ``ENOSPC`` would.
``test_no_raw_writes`` reads the source of the library and of the paper's package and fails on
a write that does not go through the helper.
"""

from __future__ import annotations

import ast
import errno
import os
import stat
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
from _atomic import ROOT, assert_old_file_whole, run_writers

from qdensity.io import atomic_path, atomic_write, atomic_write_bytes, atomic_write_text

# ---------------------------------------------------------------------------------------------
# the writers of the library, each run twice on one file (see tests/_atomic.py)


def _save_parameters(path: Path) -> None:
    from qdensity.learning.parameters import save_parameters

    save_parameters(path, W=np.arange(12.0).reshape(3, 4), b=np.ones(3))


_FITTED: list = []


def _estimator_save(path: Path) -> None:
    from qdensity.learning.estimators import QNNClassifier

    if not _FITTED:
        X = np.random.default_rng(0).normal(size=(12, 2))
        _FITTED.append(QNNClassifier(num_qubits=2, epochs=1, verbose=False)
                       .fit(X, (X[:, 0] > 0).astype(int)))
    _FITTED[0].save(path)


def _save_snapshot(path: Path) -> None:
    from qiskit.providers.fake_provider import GenericBackendV2

    from qdensity.hardware.snapshot_files import save_snapshot

    save_snapshot(GenericBackendV2(2, seed=3), path)


def _export_circuits(path: Path) -> None:
    from qdensity.cli.export import export_circuits

    export_circuits(path.parent, [path.stem])


def _export_trials(path: Path) -> None:
    from qdensity.learning.sweep import export_trials

    trial = SimpleNamespace(number=0, state=SimpleNamespace(name="COMPLETE"), value=0.75,
                            params={"learning_rate": 0.1}, user_attrs={"seconds": 1.5})
    study = SimpleNamespace(study_name="s", direction=SimpleNamespace(name="MAXIMIZE"),
                            trials=[trial, trial])
    export_trials(study, path)


def _demo_figure(path: Path) -> None:
    from qdensity.demo import DemoConfig, _plot

    results = {name: {"curve": [(0, 0.5), (100, 0.7)], "ceiling": 0.9}
               for name in ("pure", "density")}
    _plot(results, path, DemoConfig(), "all_to_all")


def _cli_qasm(path: Path) -> None:
    import contextlib
    import io

    from qdensity.cli.main import main

    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        code = main(["build", "round_robin", "--size", "4", "--qasm", str(path), "--json"])
    if code:  # the command reports an error and exits 1: say which one
        raise OSError(errno.EFBIG if "[Errno 27]" in err.getvalue() else None, err.getvalue())


#: name -> (file name, writer(path)): every writer of the library's files
WRITERS = {
    "save_parameters .json": ("p.json", _save_parameters),
    "save_parameters .npz": ("p.npz", _save_parameters),
    "estimator save .npz": ("clf.npz", _estimator_save),
    "estimator save .json": ("clf.json", _estimator_save),
    "save_snapshot": ("device.json", _save_snapshot),
    "export_circuits": ("pyramid_4.qasm", _export_circuits),
    "export_trials .json": ("trials.json", _export_trials),
    "export_trials .csv": ("trials.csv", _export_trials),
    "demo figure": ("demo.png", _demo_figure),
    "qdensity build --qasm": ("rr.qasm", _cli_qasm),
}


@pytest.fixture(scope="module")
def size_limited(tmp_path_factory):
    return run_writers("test_atomic_writes", tmp_path_factory.mktemp("writers"))


@pytest.mark.parametrize("name", list(WRITERS))
def test_a_write_past_a_size_limit_leaves_the_old_file_whole(size_limited, name):
    assert_old_file_whole(size_limited[name], name)


# ---------------------------------------------------------------------------------------------
# the helper itself


def test_atomic_write_replaces_content_and_keeps_the_old_mode(tmp_path):
    path = tmp_path / "a.txt"
    path.write_text("old")  # the oracle's file, written by open()
    os.chmod(path, 0o640)
    with atomic_write(path) as fh:
        fh.write("new ü")
    assert path.read_bytes() == "new ü".encode()
    assert stat.S_IMODE(path.stat().st_mode) == 0o640
    assert sorted(os.listdir(tmp_path)) == ["a.txt"]
    fresh, plain = tmp_path / "fresh.bin", tmp_path / "plain.bin"
    atomic_write_bytes(fresh, b"\x00\x01")
    with open(plain, "wb") as fh:
        fh.write(b"")
    assert fresh.read_bytes() == b"\x00\x01"
    assert stat.S_IMODE(fresh.stat().st_mode) == stat.S_IMODE(plain.stat().st_mode)


def test_an_error_inside_the_block_leaves_the_old_file_and_no_temporary(tmp_path):
    path = tmp_path / "r.json"
    path.write_text('{"seeds": [0]}')
    with pytest.raises(RuntimeError, match="midway"), atomic_write(path) as fh:
        fh.write('{"seeds": [0, 1')
        raise RuntimeError("midway")
    assert path.read_text() == '{"seeds": [0]}'
    assert os.listdir(tmp_path) == ["r.json"]
    with pytest.raises(KeyboardInterrupt), atomic_path(tmp_path / "f.png") as tmp:
        assert tmp.parent == tmp_path and tmp.name.endswith(".png") and tmp.exists()
        raise KeyboardInterrupt
    assert os.listdir(tmp_path) == ["r.json"]


def test_the_file_is_synced_before_it_is_renamed(tmp_path, monkeypatch):
    calls = []
    real_fsync, real_replace = os.fsync, os.replace
    monkeypatch.setattr(os, "fsync", lambda fd: (calls.append(("fsync", os.fstat(fd).st_size)),
                                                 real_fsync(fd))[1])
    monkeypatch.setattr(os, "replace", lambda a, b: (calls.append(("replace", Path(b).name)),
                                                     real_replace(a, b))[1])
    atomic_write_text(tmp_path / "x.txt", "12345")
    assert calls[:2] == [("fsync", 5), ("replace", "x.txt")]


def test_a_link_is_written_through_and_special_files_in_place(tmp_path):
    target = tmp_path / "real.txt"
    target.write_text("old")
    link = tmp_path / "link.txt"
    link.symlink_to(target)
    atomic_write_text(link, "new")
    assert link.is_symlink() and target.read_text() == "new"
    assert sorted(os.listdir(tmp_path)) == ["link.txt", "real.txt"]
    atomic_write_text(os.devnull, "discarded")  # a device: written, not replaced
    assert stat.S_ISCHR(os.stat(os.devnull).st_mode)


def test_the_helper_refuses_bad_arguments(tmp_path):
    with pytest.raises(IsADirectoryError, match="is a folder"):
        atomic_write_text(tmp_path, "x")
    (tmp_path / "e.txt").write_text("old")
    with pytest.raises(FileExistsError, match="exists"), atomic_write(tmp_path / "e.txt", "x"):
        pass
    with pytest.raises(ValueError, match="mode must be one of"), atomic_write(tmp_path / "m",
                                                                              "a"):
        pass
    with pytest.raises(TypeError, match="text must be a str"):
        atomic_write_text(tmp_path / "t.txt", b"bytes")
    with pytest.raises(TypeError, match="data must be a bytes-like object"):
        atomic_write_bytes(tmp_path / "t.bin", "text")
    with pytest.raises(FileNotFoundError):
        atomic_write_text(tmp_path / "no-such-folder" / "t.txt", "x")
    assert sorted(os.listdir(tmp_path)) == ["e.txt"]


# ---------------------------------------------------------------------------------------------
# no raw writes: every write of the library and the paper's package goes through qdensity.io

#: method names that write a file they are given (``fig.savefig``, ``path.write_text``, ...)
_WRITE_METHODS = {"write_text", "write_bytes", "savefig", "to_csv", "to_json", "to_parquet",
                  "to_pickle", "tofile", "save_fig"}
#: module-level functions that write files: module -> names
_WRITE_FUNCTIONS = {"np": {"save", "savez", "savez_compressed", "savetxt"},
                    "numpy": {"save", "savez", "savez_compressed", "savetxt"},
                    "json": {"dump"}, "pickle": {"dump"}, "joblib": {"dump"},
                    "yaml": {"dump", "safe_dump"}, "os": {"replace", "rename", "renames"},
                    "shutil": {"copy", "copy2", "copyfile", "copytree", "move"},
                    "plt": {"savefig", "imsave"}, "tarfile": {"open"}}
#: (file, function) -> why its open() with a write mode is not a data file
_ALLOWED = {("paper/qdensity_paper/_result_files.py", "locked"):
            "a lock file beside a results file: opened for flock, never written",
            ("qdensity/learning/_study.py", "_file_lock"):
            "a lock file beside a study's storage: opened for flock, never written"}
_HELPERS = {"atomic_write", "atomic_path", "atomic_write_text", "atomic_write_bytes"}


def _mode(call: ast.Call, position: int) -> str | None:
    """The mode argument of an open-like call (positional ``position`` or ``mode=``)."""
    node = next((k.value for k in call.keywords if k.arg == "mode"), None)
    if node is None and len(call.args) > position:
        node = call.args[position]
    if node is None:
        return None
    return node.value if isinstance(node, ast.Constant) and isinstance(node.value, str) else "?"


def _raw_write(call: ast.Call) -> str | None:
    """What ``call`` writes raw, or None."""
    f = call.func
    name = f.attr if isinstance(f, ast.Attribute) else f.id if isinstance(f, ast.Name) else ""
    owner = f.value.id if isinstance(f, ast.Attribute) and isinstance(f.value, ast.Name) else ""
    if isinstance(f, ast.Attribute) and name in _WRITE_METHODS:
        return f"{name}()"
    if owner in _WRITE_FUNCTIONS and name in _WRITE_FUNCTIONS[owner]:
        return f"{owner}.{name}()"
    if name in ("open", "fdopen", "ZipFile", "NamedTemporaryFile", "mkstemp"):
        method = isinstance(f, ast.Attribute) and owner not in ("os", "io", "zipfile")
        if method and name == "open":  # Path.open(mode) or ZipFile.open(name, mode)
            modes = [a.value for a in [*call.args[:2], *(k.value for k in call.keywords
                                                          if k.arg == "mode")]
                     if isinstance(a, ast.Constant) and isinstance(a.value, str)
                     and set(a.value) <= set("rwaxbtU+")]
            mode = modes[0] if modes else None
        else:
            mode = _mode(call, 1)
        if name in ("NamedTemporaryFile", "mkstemp") or (mode and set(mode) & set("wax+?")):
            return f"{name}(..., {mode!r})"
    return None


def _within_helper(stack: list[ast.AST]) -> bool:
    for node in stack:
        if isinstance(node, (ast.With, ast.AsyncWith)):
            for item in node.items:
                call = item.context_expr
                if isinstance(call, ast.Call):
                    f = call.func
                    called = f.attr if isinstance(f, ast.Attribute) else getattr(f, "id", "")
                    if called in _HELPERS:
                        return True
    return False


def _raw_writes(path: Path) -> list[str]:
    found = []

    def visit(node: ast.AST, stack: list[ast.AST], function: str) -> None:
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            function = node.name
        if isinstance(node, ast.Call):
            what = _raw_write(node)
            rel = path.relative_to(ROOT).as_posix()
            if what and not _within_helper(stack) and (rel, function) not in _ALLOWED:
                found.append(f"{rel}:{node.lineno} {function}: {what}")
        for child in ast.iter_child_nodes(node):
            visit(child, [*stack, node], function)

    visit(ast.parse(path.read_text(encoding="utf-8")), [], "<module>")
    return found


def _sources() -> list[Path]:
    out = sorted((ROOT / "qdensity").rglob("*.py"))
    out += sorted((ROOT / "paper" / "qdensity_paper").rglob("*.py"))
    return [p for p in out if p != ROOT / "qdensity" / "io.py"]


def test_the_source_scan_finds_each_kind_of_raw_write(tmp_path):
    sample = tmp_path / "sample.py"
    sample.write_text(
        "import json, os, numpy as np\n"
        "def f(p, fig, doc):\n"
        "    p.write_text('x')\n    fig.savefig(p)\n    np.save(p, 1)\n"
        "    with open(p, 'w') as fh:\n        json.dump(doc, fh)\n"
        "    os.replace(p, p)\n    open(p).read()\n"
        "    with atomic_path(p) as tmp:\n        fig.savefig(tmp)\n")
    old_root = ROOT
    try:
        globals()["ROOT"] = tmp_path
        found = _raw_writes(sample)
    finally:
        globals()["ROOT"] = old_root
    assert [f.split(" ", 1)[0] for f in found] == [f"sample.py:{n}" for n in (3, 4, 5, 6, 7, 8)]


def test_no_raw_writes():
    found = [hit for path in _sources() for hit in _raw_writes(path)]
    assert not found, ("files written without qdensity.io's atomic helpers (a full disk would "
                       "truncate the old file):\n" + "\n".join(found))
