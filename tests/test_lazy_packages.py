"""The execution, hardware, models and gradients packages load their names on first use (PEP
562): a sampled density gradient does not import the adjoint or unary engines (numba) or the
training stack, and ``qdensity table1`` does not import the demo's (scikit-learn)."""

from __future__ import annotations

import importlib
import subprocess
import sys

import pytest

LAZY = ["qdensity.execution", "qdensity.hardware", "qdensity.models", "qdensity.gradients"]


def _run(code: str) -> None:
    subprocess.run([sys.executable, "-c", code], check=True, capture_output=True)


def test_sampled_gradient_path_imports_no_engine_it_does_not_run():
    _run(
        "import sys\n"
        "from qdensity import DensityQNN, Encoding, SamplerEngine, by_moments\n"
        "from qdensity.gradients import density_gradient_plan\n"
        "heavy = [m for m in ('numba', 'sklearn', 'qdensity.execution.statevector.adjoint',\n"
        "                     'qdensity.execution.unary', 'qdensity.learning')\n"
        "         if m in sys.modules]\n"
        "assert not heavy, heavy\n"
    )


def test_table1_command_imports_no_training_stack():
    _run(
        "import contextlib, io, sys\n"
        "from qdensity.cli.main import main\n"
        "with contextlib.redirect_stdout(io.StringIO()):\n"
        "    assert main(['table1', '--n', '4']) == 0\n"
        "assert 'sklearn' not in sys.modules and 'qdensity.learning' not in sys.modules\n"
    )


def test_demo_help_still_reads_the_demo_defaults(capsys):
    from qdensity.cli.main import main
    from qdensity.demo import DemoConfig

    with pytest.raises(SystemExit):
        main(["demo", "--help"])
    out = " ".join(capsys.readouterr().out.split())
    assert f"shot budget per model (default: {DemoConfig().budget};" in out


@pytest.mark.parametrize("package", LAZY)
def test_lazy_package_names_are_the_defining_modules_objects(package):
    pkg = importlib.import_module(package)
    assert set(pkg.__all__) == set(pkg._EXPORTS)
    for name, module in pkg._EXPORTS.items():
        assert getattr(pkg, name) is getattr(importlib.import_module(module), name)
        assert name in dir(pkg)
    with pytest.raises(AttributeError, match="no attribute"):
        pkg.no_such_name  # noqa: B018


def test_warm_start_stays_the_function_when_its_submodule_is_imported_first():
    _run(
        "import importlib, qdensity.models as m\n"
        "sub = importlib.import_module('qdensity.models.warm_start')\n"
        "from qdensity.models import warm_start\n"
        "assert callable(warm_start) and warm_start is sub.warm_start is m.warm_start\n"
    )
