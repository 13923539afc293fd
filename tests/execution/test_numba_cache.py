"""numba's on-disk cache of the compiled kernels: a read-only install must still import.

numba refuses ``cache=True`` with a ``RuntimeError`` when it finds no writable cache folder
(a read-only site-packages and no writable home); :func:`qdensity.execution._numba.jit` then
compiles in memory. The oracle is a 2x2 rotation written out by hand.
"""

from __future__ import annotations

import os
import subprocess
import sys

import pytest

from qdensity.execution import _numba

pytestmark = pytest.mark.skipif(not _numba.available(), reason="numba switched off")

_CODE = """
import numpy as np
from qdensity.execution import _numba
from qiskit import QuantumCircuit
from qdensity.circuits.gates import RBSGate
from qdensity.execution.unary import forward
from qdensity.execution.statevector import _kernels_planar  # every compiled kernel decorates
c = QuantumCircuit(2)
c.append(RBSGate(0.3), [0, 1])
out = forward(c, np.array([[1.0, 0.0]] * 64))[0]
assert np.allclose(np.ravel(out), [np.cos(0.3), np.sin(0.3)]), out
print(_numba.cache_enabled())
"""


def _run(tmp_path, code=_CODE, **env):
    full = {k: v for k, v in os.environ.items() if not k.startswith("NUMBA_")}
    full.update(env)
    return subprocess.run([sys.executable, "-c", code], env=full, capture_output=True,
                          text=True, cwd=tmp_path)


def test_kernels_compile_where_no_cache_folder_is_writable(tmp_path):
    blocker = tmp_path / "a_file"
    blocker.write_text("not a folder")
    # the only locator numba may use points below a regular file: no cache folder can exist
    done = _run(tmp_path, NUMBA_CACHE_LOCATOR_CLASSES="UserProvidedCacheLocator",
                NUMBA_CACHE_DIR=str(blocker / "cache"))
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "True"


def test_cache_switch_off(tmp_path):
    done = _run(tmp_path, QDENSITY_NUMBA_CACHE="off",
                NUMBA_CACHE_DIR=str(tmp_path / "cache"))
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "False"
    assert not (tmp_path / "cache").exists()


def test_cache_written_to_numba_cache_dir(tmp_path):
    done = _run(tmp_path, NUMBA_CACHE_DIR=str(tmp_path / "cache"))
    assert done.returncode == 0, done.stderr
    assert any(p.suffix == ".nbi" for p in (tmp_path / "cache").rglob("*"))


_BITS = """
import hashlib
import numpy as np
from qdensity.circuits.ansatze import round_robin
from qdensity.execution.unary import compile_unary, forward, vjp
rng = np.random.default_rng(7)
for n, B in ((3, 3), (6, 37), (6, 64)):  # one compiled call; blocks of a generic, a literal width
    c = compile_unary(round_robin(n))
    theta = rng.uniform(-np.pi, np.pi, c.num_parameters)
    rows = rng.uniform(-np.pi, np.pi, (B, c.num_parameters))
    X, W = rng.normal(size=(B, n)), rng.normal(size=(B, n))
    for out in (forward(c, X, theta), *vjp(c, X, theta, W, reduce="sum"),
                *vjp(c, X, rows, W, reduce="sum")):
        print(hashlib.sha256(np.ascontiguousarray(out).tobytes()).hexdigest())
"""


def test_unary_numbers_do_not_depend_on_numbas_cache(tmp_path):
    """The same bits whether the kernels were compiled in the process or loaded from numba's
    disk cache.

    numba links a helper loaded from its cache as object code, which LLVM cannot inline, while
    a helper compiled in the process is inlined; a sum under the fast-math flag "reassoc" was
    then vectorised, and so rounded, differently in the two builds (the summed gradient's last
    bits differed between a process that compiled the kernels and one that loaded them). The
    kernels now add their sums in one written order.
    """
    cache = tmp_path / "cache"

    def bits():
        done = _run(tmp_path, _BITS, NUMBA_CACHE_DIR=str(cache))
        assert done.returncode == 0, done.stderr
        return done.stdout.split()

    compiled = bits()  # an empty cache: everything compiled here (and written)
    assert len(compiled) == 3 * 5
    assert any(p.suffix == ".nbi" for p in cache.rglob("*")), "the kernels were not cached"
    loaded = bits()  # everything loaded from the cache
    assert loaded == compiled
