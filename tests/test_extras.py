"""CI installs the optional extras (torch, sweep, ibm, interop) and numba (core) so that their
tests run there, never skip: ``.ci/run`` sets ``QDENSITY_REQUIRE_EXTRAS=1`` and this test then
fails if one is missing. The core package imports without them."""

import importlib
import os
import subprocess
import sys


def test_extras_are_installed_where_required():
    if os.environ.get("QDENSITY_REQUIRE_EXTRAS") == "1":
        for name in ("torch", "optuna", "qiskit_ibm_runtime", "mthree", "numba", "pennylane",
                     "qiskit_machine_learning"):
            importlib.import_module(name)


def test_core_import_needs_neither_torch_nor_optuna():
    code = ("import sys, qdensity, qdensity.learning, qdensity.learning.sweep\n"
            "assert 'torch' not in sys.modules and 'optuna' not in sys.modules\n")
    subprocess.run([sys.executable, "-c", code], check=True)
