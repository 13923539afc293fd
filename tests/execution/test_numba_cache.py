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


def _run(tmp_path, **env):
    full = {k: v for k, v in os.environ.items() if not k.startswith("NUMBA_")}
    full.update(env)
    return subprocess.run([sys.executable, "-c", _CODE], env=full, capture_output=True,
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
