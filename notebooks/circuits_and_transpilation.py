# ---
# jupyter:
#   jupytext:
#     text_representation:
#       extension: .py
#       format_name: percent
#       format_version: '1.3'
#       jupytext_version: 1.19.6
#   kernelspec:
#     display_name: Python 3
#     language: python
#     name: python3
# ---

# %% [markdown]
# # Circuits and transpilation
#
# Every construction of the paper at gate level, then what it costs on hardware:
#
# * the **RBS gate** (eq. 8) and the **FBS gate** (Supp. E.2), Hamming-weight preserving;
# * **unary loaders** `|x> = sum_j x_j/||x|| |e_j>` (Fig. 2, Johri et al.), three tree layouts;
# * the sub-unitary families: **OrthoQNNs** (pyramid, X, butterfly, round-robin: Fig. 9 a-d),
#   the **hardware-efficient** ansatz (Fig. 3), **equivariant** commuting XX and non-commuting
#   circuits and the **QCNN** (Methods, bars and dots);
# * the three **preparations** of a density state `rho = sum_k alpha_k U_k |x><x| U_k^dagger`
#   (eq. 1): randomised (Fig. 1c), deterministic (Fig. 1b) and LCU (Fig. 1a);
# * transpilation to an ideal target, a seeded heavy-hex device and a calibrated IBM device
#   snapshot, resource reports side by side, and OpenQASM 3 export.
#
# Sizes are small so the notebook runs in seconds; the test suite executes it and its `assert`s.

# %%
import numpy as np
from qiskit import QuantumCircuit
from qiskit.circuit.library import XXPlusYYGate
from qiskit.quantum_info import DensityMatrix, Operator, Statevector, partial_trace

from qdensity import FBSGate, RBSGate, is_hamming_weight_preserving, unary_loader
from qdensity.circuits import rbs_matrix

rng = np.random.default_rng(0)
theta = 0.37
# RBS(theta) is a Givens rotation on the unary states |01>, |10> and the identity elsewhere
c, s = np.cos(theta), np.sin(theta)
m = rbs_matrix(theta)
assert np.allclose(m[np.ix_([1, 2], [1, 2])], [[c, -s], [s, c]])
assert np.allclose(m[0, 0], 1) and np.allclose(m[3, 3], 1)
# ... and it equals Qiskit's XXPlusYYGate(2 theta, pi/2): a native gate on some hardware
assert Operator(RBSGate(theta)).equiv(Operator(XXPlusYYGate(2 * theta, np.pi / 2)))
m.round(3)

# %% [markdown]
# The FBS gate couples the first and last qubit of a block with a sign set by the parity of the
# qubits in between (Supp. E.2, eq. 24). On unary inputs (one excitation) it acts as an RBS on
# its end qubits, whatever the block's width:

# %%
for j in range(3):                       # the three unary states of 3 qubits
    x = np.zeros(3)
    x[j] = 1.0
    fbs = QuantumCircuit(3)
    fbs.initialize(Statevector.from_int(2**j, 8))
    fbs.append(FBSGate(theta, 3), [0, 1, 2])
    rbs = QuantumCircuit(3)
    rbs.initialize(Statevector.from_int(2**j, 8))
    rbs.append(RBSGate(theta), [0, 2])
    assert Statevector(fbs).equiv(Statevector(rbs))
print('FBS = RBS on every unary input of 3 qubits')

# %% [markdown]
# ## Unary loaders (Fig. 2)
#
# One `X` gate and `d - 1` RBS gates in a binary tree. The amplitude of `|e_j>` (statevector
# entry `2**j`) is `x_j / ||x||`, signs and zeros included. The three layouts trade depth for
# nearest-neighbour structure:

# %%
x = np.array([0.5, -1.0, 0.0, 2.0, 0.3, -0.7, 1.1, 0.4])
for layout in ('parallel', 'diagonal', 'semi_diagonal'):
    qc = unary_loader(x, layout=layout)
    amps = Statevector(qc).data.real[2 ** np.arange(len(x))]
    assert np.allclose(amps, x / np.linalg.norm(x))
    print(f"{layout:>14}: {qc.count_ops().get('rbs', 0)} RBS gates, depth {qc.depth()}")
print(unary_loader(x[:4]).draw('text'))

# %% [markdown]
# ## The sub-unitary families
#
# Every Hamming-weight-preserving family (Fig. 9) acts on the unary subspace as an orthogonal
# matrix; the others (hardware-efficient, equivariant, QCNN) do not preserve it. The table
# counts trainable parameters and gates before any compilation.

# %%
from qdensity.circuits.ansatze import (
    butterfly,
    equivariant_commuting,
    equivariant_noncommuting,
    hardware_efficient,
    pyramid,
    qcnn,
    round_robin,
    x_circuit,
)

n = 4
families = {
    'pyramid (Fig. 9a)': pyramid(n),
    'X (Fig. 9b)': x_circuit(n),
    'butterfly (Fig. 9c)': butterfly(n),
    'round-robin (Fig. 9d)': round_robin(n),
    'hardware-efficient, D=2 (Fig. 3)': hardware_efficient(n, 2),
    'equivariant XX (Methods)': equivariant_commuting(n, 'X'),
    'equivariant non-commuting, 1 layer': equivariant_noncommuting(n, 1),
    'QCNN (Methods)': qcnn(n),
}
print(f"{'family':<36}{'params':>7}{'gates':>7}  HW-preserving")
for name, qc in families.items():
    print(f"{name:<36}{qc.num_parameters:>7}{qc.size():>7}  {is_hamming_weight_preserving(qc)}")
assert families['pyramid (Fig. 9a)'].num_parameters == n * (n - 1) // 2
assert families['round-robin (Fig. 9d)'].num_parameters == n * (n - 1) // 2
assert families['butterfly (Fig. 9c)'].num_parameters == n // 2 * int(np.log2(n))
assert is_hamming_weight_preserving(families['round-robin (Fig. 9d)'])
assert not is_hamming_weight_preserving(families['hardware-efficient, D=2 (Fig. 3)'])
print(families['round-robin (Fig. 9d)'].draw('text'))

# %% [markdown]
# The round-robin circuit (Fig. 6) has `n - 1` layers of disjoint RBS gates, and every pair of
# qubits meets once. Cut into its layers it gives the `n - 1` sub-unitaries of the density
# OrthoQNN; each layer is one commuting block, which is what makes its gradient cheap (Table 1,
# see the gradients notebook).

# %%
from qdensity import by_moments, moments

rr = round_robin(n)
pairs = [tuple(sorted(rr.find_bit(q).index for q in inst.qubits)) for inst in rr.data]
assert sorted(pairs) == [(i, j) for i in range(n) for j in range(i + 1, n)]   # each pair once
dec = by_moments(rr)
print(dec, [c.num_parameters for c in dec.sub_unitaries])
assert dec.num_subunitaries == n - 1 == len(moments(rr))

# %% [markdown]
# ## Preparing the density state: randomised, deterministic, LCU (Fig. 1)
#
# * **randomised** (Fig. 1c): `K` circuits `U_k V(x)`; each shot runs circuit `k` with
#   probability `alpha_k`, so `rho` holds on average, with no extra qubits;
# * **deterministic** (Fig. 1b, Supp. I.2): `Load(sqrt(alpha))` on a `K`-qubit register `mix`,
#   then `U_k` controlled by `mix[k]`; tracing `mix` out leaves exactly `rho` on `data`;
# * **LCU** (Fig. 1a): the deterministic circuit followed by `Load(sqrt(alpha))^dagger`;
#   post-selecting `mix = 0...0` leaves `sum_k alpha_k U_k |x>` normalised, with success
#   probability `||sum_k alpha_k U_k |x>||^2`.
#
# We check each against the definition with exact statevectors (7 qubits here).

# %%
from qdensity.circuits.preparation import (
    lcu_postselected_state,
    lcu_success_probability,
    prepare_all,
)

subs = [c.assign_parameters(rng.uniform(-np.pi, np.pi, c.num_parameters))
        for c in dec.sub_unitaries]
alpha = np.array([0.5, 0.3, 0.2])
loader = unary_loader([0.4, -0.9, 0.6, 0.2])
prep = prepare_all(subs, alpha, loader)
K = len(subs)

outputs = [Statevector(loader.compose(u)) for u in subs]                # U_k |x>
rho = DensityMatrix(sum(a * np.outer(psi.data, psi.data.conj())  # eq. 1
                        for a, psi in zip(alpha, outputs, strict=True)))
# randomised: one circuit per k, the mixture made by drawing k ~ alpha per shot
assert all(Statevector(c).equiv(psi) for c, psi in zip(prep['randomised'], outputs, strict=True))
# deterministic: trace out the mix register (qubits 0 .. K-1)
marginal = partial_trace(Statevector(prep['deterministic']), list(range(K)))
assert np.allclose(marginal.data, rho.data, atol=1e-10)
# LCU: the post-selected state and the success probability
lcu = sum(a * psi.data for a, psi in zip(alpha, outputs, strict=True))
p_success = lcu_success_probability(subs, alpha, loader)
assert np.isclose(p_success, np.linalg.norm(lcu) ** 2)
assert lcu_postselected_state(subs, alpha, loader).equiv(Statevector(lcu / np.linalg.norm(lcu)))
print(f"purity of rho: {rho.purity().real:.3f}; LCU success probability: {p_success:.3f}")
print(prep['randomised'][0].draw('text'))   # V(x) then U_1: the circuit of one shot with k = 1

# %% [markdown]
# ## Transpilation and resources
#
# `get_target` names a device: `ideal` (all-to-all), `heavy_hex` (a seeded `GenericBackendV2` on
# IBM's heavy-hex lattice with sampled T1/T2, gate and readout errors), `rbs_native` (a device
# whose native two-qubit gate is the beam splitter) and, with the `ibm` extra, every calibrated
# device snapshot of `qiskit_ibm_runtime.fake_provider` (`fake_nairobi`, `fake_torino`, ...).
# `resource_report` compiles once and counts the two-qubit gates and depths; `compare_reports`
# prints them side by side with ratios to the first column. Each RBS costs two CZ/CX gates on
# IBM-like hardware (the paper's counting), one gate on `rbs_native`, and routing adds SWAPs on
# sparse lattices.

# %%
import importlib.util

from qdensity import compare_reports, get_target, resource_report

circuits = {'pyramid': pyramid(n), 'round-robin': rr, 'butterfly': butterfly(n),
            'deterministic (K=3)': prep['deterministic'], 'LCU (K=3)': prep['lcu']}
targets = {'ideal': None, 'heavy_hex': get_target('heavy_hex', 7, seed=3, noise=False),
           'rbs_native': 'rbs_native'}
if importlib.util.find_spec('qiskit_ibm_runtime') is not None:
    # a 7-qubit IBM snapshot
    targets['fake_nairobi'] = get_target('fake_nairobi', seed=3, noise=False)
else:
    print("device snapshots need the ibm extra: pip install -e '.[ibm]' (qiskit-ibm-runtime)")
reports = {}
for cname, circ in circuits.items():
    reports[cname] = {t: resource_report(circ, tgt, seed=0) for t, tgt in targets.items()}
    print(cname)
    print(compare_reports(reports[cname]))
    print()
# each RBS is two two-qubit gates on a CZ/CX device with all-to-all connectivity ...
n_rbs = pyramid(n).count_ops()['rbs']
assert reports['pyramid']['ideal'].two_qubit_count == 2 * n_rbs
# ... and exactly one native gate on the beam-splitter device
assert reports['pyramid']['rbs_native'].two_qubit_count == n_rbs
# a sparse lattice never needs fewer two-qubit gates than all-to-all connectivity
assert all(r['heavy_hex'].two_qubit_count >= r['ideal'].two_qubit_count for r in reports.values())

# %%
import matplotlib.pyplot as plt

fig, ax = plt.subplots(figsize=(7, 3))
width = 0.8 / len(targets)
for i, t in enumerate(targets):
    ax.bar(np.arange(len(circuits)) + i * width, [reports[c][t].two_qubit_count for c in circuits],
           width, label=t)
ax.set_xticks(np.arange(len(circuits)) + 0.4 - width / 2, list(circuits), rotation=15)
ax.set_ylabel('two-qubit gates')
ax.legend()
ax.set_title(f'n = {n} data qubits')
plt.show()

# %% [markdown]
# The ancilla preparations (deterministic, LCU) pay for their controlled sub-unitaries: each
# controlled RBS is far more than two CZs, which is why the paper trains with the randomised
# preparation (Fig. 1c, no extra qubits, no controlled gates) and keeps the deterministic one for
# inference.
#
# ## OpenQASM 3 export
#
# Any circuit, compiled or not, exports with `qiskit.qasm3.dumps`. The reference catalogue
# (`qdensity export`, directory `circuits/`) writes every builder unrolled into `stdgates.inc`
# with its trainable and data angles as `input float[64]`, so a provider binds them; the text
# reloads with `qiskit.qasm3.loads` (needs `qiskit-qasm3-import`).

# %%
from qiskit import qasm3

from qdensity.cli.export import reference_qasm3, symbolic_circuit

compiled = targets['heavy_hex'].transpile(pyramid(n).assign_parameters(rng.uniform(-1, 1, 6)))
text = qasm3.dumps(compiled)
print(text[:400], '...')
assert text.startswith('OPENQASM 3.0;')

ref = reference_qasm3('round_robin_4')
print('\n'.join(ref.splitlines()[:12]), '\n...')
assert ref.count('input float[64]') == symbolic_circuit('round_robin_4').num_parameters == 6
if importlib.util.find_spec('qiskit_qasm3_import') is not None:
    loaded = qasm3.loads(ref)
    values = rng.uniform(-np.pi, np.pi, loaded.num_parameters)
    # the inputs come back as _θ_0_ .. _θ_5_ (OpenQASM identifiers), in that order
    names = sorted(loaded.parameters, key=lambda p: p.name)
    a = loaded.assign_parameters(dict(zip(names, values, strict=True)))
    b = symbolic_circuit('round_robin_4').assign_parameters(values)
    assert Operator(a).equiv(Operator(b))
    print('reloaded OpenQASM 3 equals the builder up to a global phase')
