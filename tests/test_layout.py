"""The package layout: one-way imports along the spine, no cycles, the first release's import
paths kept, and modules of one job under ~500 lines (issue "Layout").

The import graph is read from the source with ``ast`` (module-level and function-level imports
alike), independently of what Python happens to have imported.
"""

from __future__ import annotations

import ast
import importlib
import subprocess
import sys
from pathlib import Path

import pytest

import qdensity
from qdensity import _aliases

ROOT = Path(qdensity.__file__).resolve().parent

#: Subpackages from the bottom of the spine to the top: a module may import only from its own
#: layer or a layer below it (docs/design.md, "The spine"; CONTRIBUTING.md).
LAYERS = [
    "_lazy",
    "_constraints",
    "validation",
    "progress",
    "cluster",
    "_aliases",
    "datasets",
    "analysis",
    "circuits",
    "hardware",
    "execution",
    "models",
    "gradients",
    "learning",
    "experiments",
    "cli",
]

#: Names that moved to a higher layer than their old module and so are no longer re-exported
#: there: old module, name -> new home.
MOVED = {("qdensity.pauli", "rbs_diagonalising_layer"): "qdensity.gradients.diagonalising"}

# The public API of the first release (every module's ``__all__`` before the layout change).
OLD_API: dict[str, list[str]] = {
    'qdensity': [
        'Decomposition', 'DensityQNN', 'Encoding', 'ExactEngine', 'FBSGate', 'FixedMixture',
        'GatedMixture', 'Plan', 'QNNClassifier', 'QNNRegressor', 'RBSGate', 'SamplerEngine',
        'ShotLedger', 'SoftmaxMixture', '__version__', 'by_moments', 'compare_reports', 'copies',
        'cyclic_moments', 'distribution_loader', 'expectation_plan', 'get_target',
        'is_hamming_weight_preserving', 'known_targets', 'loader_angles', 'matrix_loader',
        'moments', 'odd_even', 'probabilities_plan', 'resource_report', 'unary_loader',
        'unary_loader_template',
    ],
    'qdensity.analysis': [
        'HW_PRESERVING_GATES', 'depth_of_gates', 'instruction_generator',
        'is_hamming_weight_preserving', 'moment_indices', 'moments', 'parameter_of',
    ],
    'qdensity.ansatze': [
        'angle_encoding', 'bars_and_dots', 'butterfly', 'chebyshev_dataset',
        'equivariant_commuting', 'equivariant_noncommuting', 'equivariant_observable',
        'hardware_efficient', 'pairs_circuit', 'pyramid', 'qcnn', 'qcnn_layers',
        'qcnn_readout_qubit', 'reuploading', 'round_robin', 'round_robin_pairs',
        'translation_classes', 'x_circuit',
    ],
    'qdensity.ansatze.equivariant': [
        'PAULIS', 'angle_encoding', 'bars_and_dots', 'equivariant_commuting',
        'equivariant_noncommuting', 'equivariant_observable', 'translation_classes',
    ],
    'qdensity.ansatze.hamming': [
        'butterfly', 'pairs_circuit', 'pyramid', 'round_robin', 'x_circuit',
    ],
    'qdensity.ansatze.hardware_efficient': ['ENTANGLEMENTS', 'ROTATIONS', 'hardware_efficient'],
    'qdensity.ansatze.qcnn': [
        'CONV_PARAMETERS', 'POOL_PARAMETERS', 'qcnn', 'qcnn_layers', 'qcnn_readout_qubit',
    ],
    'qdensity.ansatze.reuploading': ['ENCODINGS', 'chebyshev_dataset', 'reuploading'],
    'qdensity.cli': ['BUILDERS', 'build_circuit', 'main'],
    'qdensity.decompositions': [
        'Decomposition', 'by_moments', 'copies', 'cyclic_moments', 'independent', 'odd_even',
        'trainable_parameters',
    ],
    'qdensity.demo': ['DemoConfig', 'load_digits_features', 'run_demo'],
    'qdensity.engines': [
        'ExactEngine', 'LedgerEntry', 'SamplerEngine', 'ShotLedger', 'bitarray_to_probabilities',
    ],
    'qdensity.export': [
        'INDEX_NAME', 'QASM2_BASIS', 'REFERENCE_BUILDERS', 'REFERENCE_DESCRIPTIONS',
        'bind_reference', 'check_circuits', 'export_circuits', 'index_markdown', 'main',
        'reference_circuit', 'reference_qasm', 'reference_seed',
    ],
    'qdensity.gates': ['FBSGate', 'RBSGate', 'fbs_matrix', 'rbs_matrix'],
    'qdensity.gradients': [
        'CommutingBlockGradient', 'CommutingGradient', 'DensityGradient', 'chain_rule',
        'commuting_block_gradient', 'commuting_blocks', 'commuting_gradient',
        'density_gradient_plan', 'expand_occurrences', 'parameter_shift_plan', 'shift_rules',
        'subunitary_jacobian_plan',
    ],
    'qdensity.gradients.commuting': [
        'BLOCK_METHODS', 'CommutingBlockGradient', 'CommutingGradient', 'commuting_block_gradient',
        'commuting_blocks', 'commuting_gradient', 'trainable_parameters',
    ],
    'qdensity.gradients.density': [
        'DensityGradient', 'METHODS', 'density_gradient_plan', 'subunitary_jacobian_plan',
    ],
    'qdensity.gradients.shift': [
        'ShiftRule', 'expand_occurrences', 'parameter_shift_plan', 'shift_rules',
    ],
    'qdensity.loaders': [
        'LAYOUTS', 'distribution_loader', 'loader_angles', 'loader_start_qubit', 'matrix_loader',
        'unary_loader', 'unary_loader_template',
    ],
    'qdensity.losses': [
        'accuracy', 'binary_cross_entropy', 'binary_cross_entropy_with_logits', 'cross_entropy',
        'cross_entropy_with_logits', 'l2_penalty', 'mse',
    ],
    'qdensity.mixtures': [
        'FixedMixture', 'GatedMixture', 'Mixture', 'SoftmaxMixture', 'as_mixture', 'softmax',
    ],
    'qdensity.models': ['DensityQNN', 'Encoding', 'READOUTS', 'bind_rows'],
    'qdensity.nn': [
        'GELU', 'Layer', 'Linear', 'Normalize', 'ReLU', 'Sequential', 'Softmax', 'get_flat',
        'load_parameters', 'save_parameters', 'set_flat',
    ],
    'qdensity.noise': ['DEFAULT_BASIS_GATES', 'VIRTUAL_GATES', 'noise_from_backend', 'noise_model'],
    'qdensity.optim': ['Adam', 'Optimizer', 'RMSprop', 'SGD'],
    'qdensity.pauli': [
        'as_pauli_list', 'commutation_matrix', 'conjugate_two_qubit', 'diagonalising_clifford',
        'first_noncommuting_pair', 'paulis_commute_pairwise', 'rbs_diagonalising_layer',
        'z_string_values',
    ],
    'qdensity.plans': [
        'CircuitJob', 'Estimate', 'JobResult', 'Plan', 'basis_rotation', 'check_observable',
        'diagonal_values', 'expectation_plan', 'measured', 'postselect_hamming_weight',
        'probabilities_plan', 'z_parities',
    ],
    'qdensity.preparation': [
        'DATA_REGISTER', 'MIX_REGISTER', 'PreparationCircuits', 'controlled_subunitary',
        'deterministic_circuit', 'hw_generative_circuit', 'lcu_circuit', 'lcu_postselected_state',
        'lcu_success_probability', 'prepare_all', 'randomised_circuits',
    ],
    'qdensity.resources': [
        'DEFAULT_BASIS', 'METRICS', 'ResourceReport', 'compare_reports', 'resource_report',
    ],
    'qdensity.schedulers': [
        'NeymanScheduler', 'PerShotScheduler', 'ProportionalScheduler', 'ScheduleResult',
        'Scheduler', 'ShotSource', 'allocate_neyman', 'allocate_proportional', 'discrete_source',
        'neyman', 'per_shot', 'per_shot_variance', 'proportional', 'sampler_source',
        'stratified_variance',
    ],
    'qdensity.table1': ['ANSATZE', 'format_table1', 'table1', 'table1_row'],
    'qdensity.targets': [
        'HardwareTarget', 'RBS_NATIVE_BASIS', 'RBS_NATIVE_NOISE', 'SIMULATION_METHODS',
        'get_target', 'gpu_available', 'heavy_hex_distance', 'known_targets',
    ],
    'qdensity.tomography': [
        'SIGN_FACTOR', 'TomographyResult', 'bridge_circuit', 'bridge_pairs', 'reconstruct',
        'shots_for_error', 'tomography_circuits',
    ],
    'qdensity.training': ['History', 'QNNClassifier', 'QNNRegressor', 'QuantumLayer'],
    'qdensity.unary': [
        'UnaryCircuit', 'compile_unary', 'forward', 'jacobian', 'orthogonal_matrix', 'vjp',
    ],
    'qdensity.validation': [
        'as_parameter_rows', 'as_rng', 'check_circuit', 'check_distribution',
        'check_nonzero_vector', 'check_parameter_values', 'check_positive_int',
        'check_real_vector', 'check_rows_sum_to_one', 'seed_int',
    ],
}


def _module_name(path: Path) -> str:
    parts = list(path.relative_to(ROOT.parent).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts = parts[:-1]
    return ".".join(parts)


MODULES = {_module_name(p): p for p in sorted(ROOT.rglob("*.py"))}


def _imports(name: str, path: Path) -> set[str]:
    """qdensity modules that ``name`` imports, at any depth of its source."""
    is_pkg = path.name == "__init__.py"
    package = name if is_pkg else name.rpartition(".")[0]
    out: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            targets = [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")[: len(package.split(".")) - node.level + 1]
                mod = ".".join(base + ([node.module] if node.module else []))
            else:
                mod = node.module or ""
            # "from pkg import sub" imports the submodule pkg.sub when there is one
            targets = [f"{mod}.{a.name}" if f"{mod}.{a.name}" in MODULES else mod
                       for a in node.names]
        else:
            continue
        for target in targets:
            if target.startswith("qdensity"):
                out.add(_aliases.resolve(target) or target)
    out.discard(name)
    return out


GRAPH = {name: _imports(name, path) for name, path in MODULES.items()}


def _layer(module: str) -> str:
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else ""


def _find_cycle(graph: dict[str, set[str]]) -> list[str] | None:
    state: dict[str, int] = {}
    stack: list[str] = []

    def visit(node: str) -> list[str] | None:
        state[node] = 1
        stack.append(node)
        for nxt in sorted(graph.get(node, ())):
            if state.get(nxt) == 1:
                return stack[stack.index(nxt):] + [nxt]
            if nxt not in state and (found := visit(nxt)):
                return found
        stack.pop()
        state[node] = 2
        return None

    for node in sorted(graph):
        if node not in state and (found := visit(node)):
            return found
    return None


def test_cycle_finder_finds_a_cycle():
    assert _find_cycle({"a": {"b"}, "b": {"c"}, "c": {"a"}}) == ["a", "b", "c", "a"]
    assert _find_cycle({"a": {"b"}, "b": {"c"}, "c": set()}) is None


def test_every_import_names_a_real_module():
    missing = {(m, t) for m, targets in GRAPH.items() for t in targets if t not in MODULES}
    assert not missing


def test_no_import_cycle_between_modules():
    assert _find_cycle(GRAPH) is None


def test_no_import_cycle_between_packages():
    packages: dict[str, set[str]] = {}
    for module, targets in GRAPH.items():
        if module == "qdensity":
            continue
        packages.setdefault(_layer(module), set()).update(
            _layer(t) for t in targets if t != "qdensity" and _layer(t) != _layer(module))
    assert _find_cycle(packages) is None


def test_imports_run_one_way_along_the_spine():
    assert {_layer(m) for m in MODULES if m != "qdensity"} == set(LAYERS)
    upward = sorted(
        f"{module} -> {target}"
        for module, targets in GRAPH.items() if module != "qdensity"
        for target in targets
        if LAYERS.index(_layer(target)) > LAYERS.index(_layer(module))
    )
    assert not upward


def test_modules_stay_under_500_lines():
    long = {m: n for m, p in MODULES.items() if (n := len(p.read_text().splitlines())) > 500}
    assert not long


@pytest.mark.parametrize("old", sorted(OLD_API))
def test_first_release_import_paths_still_work(old):
    module = importlib.import_module(old)
    for name in OLD_API[old]:
        if (old, name) in MOVED:
            assert hasattr(importlib.import_module(MOVED[old, name]), name)
        else:
            assert hasattr(module, name), f"{old}.{name} is gone"


@pytest.mark.parametrize("short", sorted(_aliases.ALIASES))
def test_short_paths_are_the_canonical_modules(short):
    module = importlib.import_module(short)
    canonical = importlib.import_module(_aliases.ALIASES[short])
    assert module is canonical
    assert module.__name__ == module.__spec__.name == _aliases.ALIASES[short]
    parent, _, leaf = short.rpartition(".")
    assert getattr(importlib.import_module(parent), leaf) is canonical


def test_submodule_of_a_short_path_is_one_module():
    from qdensity.ansatze.hamming import round_robin
    from qdensity.circuits.ansatze.hamming import round_robin as canonical

    assert round_robin is canonical


def test_unknown_attribute_of_the_package_is_an_attribute_error():
    with pytest.raises(AttributeError, match="no_such_module"):
        qdensity.no_such_module  # noqa: B018


def test_importing_a_submodule_by_its_short_path_keeps_the_package_functions():
    """In a fresh interpreter (the first import is the one that matters): the submodule
    ``hardware_efficient`` must not replace the function of that name in ``qdensity.ansatze``."""
    code = (
        "import qdensity.ansatze.hardware_efficient\n"
        "from qdensity.ansatze import hardware_efficient\n"
        "assert hardware_efficient(2, 1).num_qubits == 2\n"
    )
    subprocess.run([sys.executable, "-c", code], check=True, capture_output=True)


def test_package_names_load_lazily_and_are_the_defining_modules_objects():
    """``import qdensity`` imports no subpackage, scikit-learn or Aer (fresh interpreter); each
    public name, on first use, is the object its defining module exports."""
    code = (
        "import sys, qdensity\n"
        "heavy = [m for m in ('sklearn', 'qiskit_aer', 'qdensity.learning', 'qdensity.models')\n"
        "         if m in sys.modules]\n"
        "assert not heavy, heavy\n"
        "from qdensity import DensityQNN\n"
        "assert 'qdensity.models.density' in sys.modules and 'sklearn' not in sys.modules\n"
    )
    subprocess.run([sys.executable, "-c", code], check=True, capture_output=True)
    assert set(qdensity.__all__) - {"__version__"} == set(qdensity._EXPORTS)
    for name, module in qdensity._EXPORTS.items():
        assert getattr(qdensity, name) is getattr(importlib.import_module(module), name)
        assert name in dir(qdensity)
    assert qdensity.circuits is importlib.import_module("qdensity.circuits")
