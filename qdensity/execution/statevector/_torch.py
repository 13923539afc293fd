"""The adjoint engine's state operations on torch tensors (``AdjointEngine(backend="torch")``).

The same compiled :class:`._program.Program` and the same adjoint sweep as the numpy path
(forward ``phi = U|0>``, ``lam_m = O_m phi``, then gate by gate backwards
``d f_m / d theta_g = 2 c_g Im <lam_m| Pi_g P_g |phi>`` and ``phi, lam <- U_g^dag phi, lam``),
on states of shape ``(..., R, 2**n)`` on a torch device, complex64 or complex128.

No index table of ``2**n`` entries is built: a state is viewed as ``(..., R, 2, ..., 2)`` with
qubit ``q`` on axis ``-1 - q`` (amplitude ``k = sum_q b_q 2^q``), so that a Pauli string is a
``flip`` of its X/Y axes and a sign on the ``|1>`` half of its Y/Z axes, and the controls of a
gate are a ``narrow`` to the ``|1>`` half of their axes (a view). Memory per row and state is
``2**n`` amplitudes, plus one temporary of the gate's support.
"""

from __future__ import annotations

import itertools

import numpy as np
from qiskit.quantum_info import SparsePauliOp

from qdensity.execution._torch import cache_of, check_fits, is_tensor, resolve_device, torch
from qdensity.execution.observables import check_observable

__all__: list[str] = []

#: ``dtype`` choices of the torch backend: complex state dtypes.
DTYPES = ("complex128", "complex64")


def resolve(device, dtype):
    """``(torch.device, complex dtype)`` of ``AdjointEngine(backend="torch", ...)``, whose
    declaration already holds ``dtype`` to None or one of :data:`DTYPES`."""
    t = torch()
    dev = resolve_device(device)
    name = str(dtype).removeprefix("torch.") if dtype is not None else "complex128"
    return dev, getattr(t, name)


def _bits(mask: int) -> list[int]:
    return [q for q in range(mask.bit_length()) if mask >> q & 1]


class _Pauli:
    """``scalar (-1)^{|k & z|} psi[k ^ x]`` on the positions where the controls are 1."""

    def __init__(self, gather):
        self.x = _bits(gather.xmask)
        self.z = _bits(gather.zmask)
        self.controls = _bits(gather.cmask)
        self.scalar = complex(gather.scalar)
        self.slices = self._slices()

    #: Diagonal strings with up to this many Z's are applied slice by slice (2**k slices).
    MAX_SLICED = 3

    def _slices(self):
        """For a diagonal string (no X or Y) of at most :data:`MAX_SLICED` Z's: its eigenvalue
        on each pattern of the Z qubits' bits; else None."""
        if self.x or len(self.z) > self.MAX_SLICED:
            return None
        return [(bits, self.scalar * (-1) ** sum(bits))
                for bits in itertools.product((0, 1), repeat=len(self.z))]

    def parts(self, v):
        """``(eigenvalue, view)`` of ``v`` per pattern of the Z qubits' bits (diagonal only)."""
        for bits, eig in self.slices:
            part = v
            for q, b in zip(self.z, bits, strict=True):
                part = part.narrow(-1 - q, b, 1)
            yield eig, part

    def select(self, v):
        for q in self.controls:
            v = v.narrow(-1 - q, 1, 1)
        return v

    def apply(self, v, factor=None):
        """A new tensor: the Pauli string on ``v`` (already narrowed to the controls), times
        ``factor`` (a tensor broadcast over the rows) if given, in the same pass."""
        p = v.flip([-1 - q for q in self.x]) if self.x else v.clone()
        for q in self.z:
            p.narrow(-1 - q, 1, 1).neg_()
        if factor is not None:
            p.mul_(factor * self.scalar if self.scalar != 1 else factor)
        elif self.scalar != 1:
            p.mul_(self.scalar)
        return p


def _view(state, n: int):
    return state.view(tuple(state.shape[:-1]) + (2,) * n)


class _Ops:
    """The ops of a Program for one device and dtype (matrices moved there once)."""

    def __init__(self, prog, device, dtype):
        from qdensity.execution.statevector._program import Rotation

        t = torch()
        self.ops: list[tuple] = []
        for op in prog.ops:
            if isinstance(op, Rotation):
                self.ops.append(("rot", _Pauli(op.gather), op.identity, op.coefficient))
            elif op.gather is not None:
                self.ops.append(("pauli", _Pauli(op.gather)))
            else:
                mat = t.as_tensor(np.array(op.matrix), dtype=dtype, device=device)
                self.ops.append(("matrix", list(op.qubits), mat, mat.conj().T.contiguous()))
        self.coefficients = t.as_tensor(prog.coefficients, device=device,
                                        dtype=t.float64 if dtype == t.complex128
                                        else t.float32)


def _ops(engine, prog) -> _Ops:
    cache = cache_of(engine)
    hit = cache.get(id(prog))
    if hit is None or hit[0] is not prog:
        hit = cache[id(prog)] = (prog, _Ops(prog, engine.device, engine.dtype))
    return hit[1]


def _matrix(v, qubits, mat):
    k = len(qubits)
    src = [-1 - q for q in reversed(qubits)]
    dst = list(range(-k, 0))
    moved = torch().movedim(v, src, dst)
    out = (moved.reshape(tuple(moved.shape[:-k]) + (2**k,)) @ mat.T).reshape(moved.shape)
    v.copy_(torch().movedim(out, dst, src))


def _fixed(v, op, inverse: bool = False) -> None:
    if op[0] == "pauli":
        sel = op[1].select(v)
        sel.copy_(op[1].apply(sel))  # a Pauli is its own inverse
    else:
        _matrix(v, op[1], op[3] if inverse else op[2])


def _trig(engine, prog, vals, n):
    """``cos`` and ``sin`` of ``c * angle``, shape (G, R, 1, ..., 1) (real, on the device)."""
    t = torch()
    real = t.float64 if engine.dtype == t.complex128 else t.float32
    theta = t.as_tensor(prog.angles(vals) * prog.scales, dtype=real, device=engine.device)
    theta = theta.T.reshape((theta.shape[1], theta.shape[0]) + (1,) * n)
    return theta.cos(), theta.sin()


def _forward(engine, prog, ops, vals):
    t = torch()
    n, R = prog.num_qubits, vals.shape[0]
    state = t.zeros((R, 2**n), dtype=engine.dtype, device=engine.device)
    state[:, 0] = 1.0
    v = _view(state, n)
    cos, sin = _trig(engine, prog, vals, n)
    g = 0
    for op in ops.ops:
        if op[0] == "rot":
            _, pauli, identity, _ = op
            sel = pauli.select(v)
            if identity:
                sel.mul_(t.complex(cos[g], -sin[g]))
            elif pauli.slices is not None:  # diagonal: one pass of phases
                for eig, part in pauli.parts(sel):
                    part.mul_(cos[g] - 1j * eig * sin[g])
            else:
                p = pauli.apply(sel, -1j * sin[g])
                sel.mul_(cos[g])
                sel.add_(p)
            g += 1
        else:
            _fixed(v, op)
    return state


class _Observable:
    """``O psi`` on the device: a real diagonal, or a sum of Pauli strings."""

    def __init__(self, obs, n: int, engine, index: int):
        t = torch()
        self.diagonal, self.terms = None, []
        if isinstance(obs, np.ndarray) and obs.ndim == 1:
            if obs.shape != (2**n,) or np.iscomplexobj(obs):
                raise ValueError(f"observables[{index}] as a diagonal must be a real vector of "
                                 f"length 2**n = {2**n}, got shape {obs.shape}")
            self.diagonal = t.as_tensor(obs, device=engine.device).to(engine.dtype)
            return
        spo = check_observable(obs, n, f"observables[{index}]").simplify()
        for pauli, coeff in zip(spo.paulis, spo.coeffs, strict=True):
            x, z = pauli.x, pauli.z
            xm = sum(1 << q for q in range(n) if x[q])
            zm = sum(1 << q for q in range(n) if z[q])
            ny = int(np.count_nonzero(x & z))
            term = _Pauli.__new__(_Pauli)
            term.x, term.z, term.controls = _bits(xm), _bits(zm), []
            term.scalar = complex(coeff) * (-1j) ** int(pauli.phase) * (-1j) ** ny
            self.terms.append(term)

    def apply(self, state, n: int):
        out = state * self.diagonal if self.diagonal is not None else torch().zeros_like(state)
        v = _view(state, n)
        for term in self.terms:
            out += term.apply(v).reshape(state.shape)
        return out


def _snapshot(obs):
    """What an observable is now (to see an in-place change of a cached one)."""
    if isinstance(obs, SparsePauliOp):
        p = obs.paulis
        return p.x.copy(), p.z.copy(), p.phase.copy(), obs.coeffs.copy()
    if isinstance(obs, np.ndarray):
        return (obs.copy(),)
    return (obs,)


def _same(a: tuple, b: tuple) -> bool:
    return len(a) == len(b) and all(
        (x == y) if isinstance(x, str) else
        (isinstance(x, np.ndarray) and isinstance(y, np.ndarray) and x.shape == y.shape
         and np.array_equal(x, y)) for x, y in zip(a, b, strict=True))


def _observables(engine, observables, n: int) -> list[_Observable]:
    """The observables on the device; the last call's are reused while the same objects (a
    training loop) are unchanged (checking and simplifying an operator costs milliseconds)."""
    if isinstance(observables, (str, SparsePauliOp, np.ndarray)):
        observables = [observables]
    observables = list(observables)
    last = cache_of(engine).get("observables")
    if (last is not None and last[0] == n and len(last[1]) == len(observables)
            and all(a is b or (isinstance(a, str) and a == b)
                    for a, b in zip(last[1], observables, strict=True))
            and all(_same(_snapshot(o), s) for o, s in zip(observables, last[2], strict=True))):
        return last[3]
    out = [_Observable(o, n, engine, i) for i, o in enumerate(observables)]
    if not out:
        raise ValueError("observables must hold at least one observable")
    cache_of(engine)["observables"] = (n, observables, [_snapshot(o) for o in observables],
                                       out)
    return out


def _real_dot(a, b):
    """``Re sum_k conj(a_k) b_k`` over the last axis (broadcast)."""
    return (a.conj() * b).real.sum(dim=-1)


def _fits(engine, rows: int, n: int, states: int, what: str) -> None:
    item = 16 if engine.dtype == torch().complex128 else 8
    check_fits(engine.device, rows * 2**n * item * states, what)


def _out(x, like):
    """``x`` (a tensor) as the caller gave: a tensor for tensor values, else numpy."""
    return x if is_tensor(like) else x.cpu().numpy()


def statevector(engine, prog, vals, like):
    """:meth:`AdjointEngine.statevector` on the torch backend."""
    n, R = prog.num_qubits, vals.shape[0]
    ops = _ops(engine, prog)
    _fits(engine, R, n, 1, f"the statevectors ({R} rows, {n} qubits)")
    out = torch().empty((R, 2**n), dtype=engine.dtype, device=engine.device)
    for sl in engine._chunks(R, n, 1):
        _fits(engine, sl.stop - sl.start, n, 2, f"a chunk of {n}-qubit states")
        out[sl] = _forward(engine, prog, ops, vals[sl])
    return _out(out, like)


def expectation(engine, prog, observables, vals, like):
    """:meth:`AdjointEngine.expectation` on the torch backend."""
    n, R = prog.num_qubits, vals.shape[0]
    obs, ops = _observables(engine, observables, n), _ops(engine, prog)
    real = torch().float64 if engine.dtype == torch().complex128 else torch().float32
    out = torch().empty((R, len(obs)), dtype=real, device=engine.device)
    for sl in engine._chunks(R, n, 2):
        _fits(engine, sl.stop - sl.start, n, 3, f"a chunk of {n}-qubit states")
        psi = _forward(engine, prog, ops, vals[sl])
        for m, o in enumerate(obs):
            out[sl, m] = _real_dot(psi, o.apply(psi, n))
    return _out(out, like)


def value_and_gradient(engine, prog, observables, vals, cols, like):
    """:meth:`AdjointEngine.value_and_gradient` on the torch backend (``cols``: wrt)."""
    t = torch()
    n, R = prog.num_qubits, vals.shape[0]
    obs, ops = _observables(engine, observables, n), _ops(engine, prog)
    M = len(obs)
    real = t.float64 if engine.dtype == t.complex128 else t.float32
    sub = prog.coefficients[cols]  # (W, G): d angle_g / d value[cols]
    needs = np.any(sub != 0, axis=0)
    used = np.flatnonzero(needs)
    stop = prog.rotations[int(used.min())] if used.size else len(prog.ops)
    chain = ops.coefficients[t.as_tensor(cols, dtype=t.int64, device=engine.device)].T
    values_out = t.empty((R, M), dtype=real, device=engine.device)
    jac = t.zeros((R, M, cols.size), dtype=real, device=engine.device)
    # per row: [phi, lam_1 .. lam_M], a gate's temporary of the same size, M products of a
    # derivative, and a spare state
    copies = 3 * M + 3
    for sl in engine._chunks(R, n, copies):
        rows = sl.stop - sl.start
        _fits(engine, rows, n, copies, f"the adjoint sweep of {rows} row(s) of {n}-qubit "
              f"states with {M} observable(s)")
        phi = _forward(engine, prog, ops, vals[sl])
        both = t.empty((M + 1,) + tuple(phi.shape), dtype=engine.dtype, device=engine.device)
        both[0] = phi
        del phi
        for m, o in enumerate(obs):
            both[m + 1] = o.apply(both[0], n)
        values_out[sl] = _real_dot(both[0], both[1:]).T
        if not used.size:
            continue
        cos, sin = _trig(engine, prog, vals[sl], n)
        v = _view(both, n)
        dtheta = t.zeros((rows, M, len(prog.rotations)), dtype=real, device=engine.device)
        dims = tuple(range(2, v.ndim))
        g = len(prog.rotations)
        for i in range(len(ops.ops) - 1, stop - 1, -1):
            op = ops.ops[i]
            if op[0] != "rot":
                _fixed(v, op, inverse=True)
                continue
            g -= 1
            _, pauli, identity, coef = op
            sel = pauli.select(v)
            if not identity and pauli.slices is not None:  # diagonal: no gathered copy
                if needs[g]:
                    acc = sum(eig * (part[1:].conj() * part[0]).sum(dim=dims)
                              for eig, part in pauli.parts(sel))
                    dtheta[:, :, g] = (2.0 * coef * acc.imag).T
                for eig, part in pauli.parts(sel):
                    part.mul_(cos[g] + 1j * eig * sin[g])
                continue
            p = sel.clone() if identity else pauli.apply(sel)
            if needs[g]:
                dtheta[:, :, g] = (2.0 * coef * (sel[1:].conj() * p[0]).imag.sum(dim=dims)).T
            if identity:
                sel.mul_(t.complex(cos[g], sin[g]))
            else:
                p.mul_(1j * sin[g])
                sel.mul_(cos[g])
                sel.add_(p)
            del p
        jac[sl] = dtheta @ chain
    return _out(values_out, like), _out(jac, like)
