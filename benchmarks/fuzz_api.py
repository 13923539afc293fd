"""Run the fuzzer generated from the declarations long, and time the declared checks.

``tests/fuzz/test_fuzz_declared.py`` draws a few values per declared argument in CI; this
script runs it with ``--examples N`` per argument (hypothesis, non-derandomised), then prints
how many arguments were fuzzed and the cost of a declared check on a few hot entry points, as
the ratio of a decorated call to the same body called undecorated (``__wrapped__``).

Usage::

    python benchmarks/fuzz_api.py --examples 200
    python benchmarks/fuzz_api.py --examples 50 -k circuits   # one part of the surface
    python benchmarks/fuzz_api.py --examples 0                # only the timings
    python benchmarks/fuzz_api.py --examples 0 --extremes     # valid extreme floats too

``--extremes`` calls every declared callable with each real-number argument at valid extremes
(the smallest subnormal, 1e-300, 1e300, the largest float, the declared bounds; the other
arguments at their declared examples) and lists the calls that raise anything but
``ValueError``/``TypeError`` (an ``OverflowError`` or ``ZeroDivisionError`` inside a formula)
or run longer than 10 s.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import timeit
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def fuzz(examples: int, select: str | None) -> int:
    """Run the generated fuzzer with ``examples`` draws per argument; its exit status."""
    env = dict(os.environ, QDENSITY_FUZZ_EXAMPLES=str(examples), HYPOTHESIS_PROFILE="explore")
    cmd = [sys.executable, "-m", "pytest", "-q", "-p", "no:randomly", "-n", "0",
           str(ROOT / "tests" / "fuzz" / "test_fuzz_declared.py")]
    if select:
        cmd += ["-k", select]
    return subprocess.call(cmd, env=env, cwd=ROOT)


def timings(number: int = 2000) -> list[tuple[str, float, float]]:
    """``(call, decorated us, undecorated us)`` for a few hot entry points."""
    import numpy as np
    from qiskit.circuit import QuantumCircuit

    from qdensity.circuits.gates import RBSGate
    from qdensity.execution.plans import CircuitJob

    qc = QuantumCircuit(2, 2)
    qc.measure([0, 1], [0, 1])
    vals = np.zeros((64, 0))
    big = np.zeros((4096, 0))
    cases = {
        "RBSGate(0.3)": (RBSGate, (0.3,)),
        "CircuitJob(qc, (64, 0) rows, 100)": (CircuitJob, (qc, vals, 100)),
        "CircuitJob(qc, (4096, 0) rows, 100)": (CircuitJob, (qc, big, 100)),
        "RBSGate(np.float32(0.3))": (RBSGate, (np.float32(0.3),)),
    }
    out = []
    for name, (fn, args) in cases.items():
        raw = fn.__init__.__wrapped__ if isinstance(fn, type) else fn.__wrapped__

        def bare(fn=fn, raw=raw, args=args):
            obj = object.__new__(fn) if isinstance(fn, type) else None
            return raw(obj, *args) if obj is not None else raw(*args)

        def decorated(fn=fn, args=args):
            return fn(*args)

        t_dec = min(timeit.repeat(decorated, number=number, repeat=5)) / number * 1e6
        t_raw = min(timeit.repeat(bare, number=number, repeat=5)) / number * 1e6
        out.append((name, t_dec, t_raw))
    return out


def extremes(seconds: int = 10) -> list[str]:
    """Calls of declared callables at valid extreme real numbers that fail other than by a
    ``ValueError``/``TypeError``, or take longer than ``seconds`` (see the module)."""
    import signal

    sys.path[:0] = [str(ROOT / "tests" / "fuzz")]
    import test_fuzz_declared as fuzzer
    from _api import declarations, parameters, public_callables

    from qdensity.validation import Interval

    class _Late(Exception):
        pass

    def late(*_):
        raise _Late

    signal.signal(signal.SIGALRM, late)
    found = []
    for name, obj in public_callables().items():
        decl = declarations(obj)
        for arg, c in decl.items():
            floats = [m for m in getattr(c, "members", [c])
                      if isinstance(m, Interval) and m.kind is float]
            if not floats:
                continue
            values = [v for v in (5e-324, 1e-300, 1e300, 1.7e308, floats[0].low, floats[0].high)
                      if v is not None and c.is_satisfied_by(v)]
            try:
                base = {k: fuzzer._example(decl[k]) if k in decl else None
                        for k, p in parameters(obj).items() if k != arg and p.default is p.empty}
            except LookupError:
                continue
            for v in values:
                signal.alarm(seconds)
                try:
                    fuzzer._call(obj, {**base, arg: v})
                except (ValueError, TypeError):
                    pass
                except _Late:
                    found.append(f"{name}({arg}={v!r}): longer than {seconds} s")
                except Exception as exc:  # noqa: BLE001 - what the run reports
                    found.append(f"{name}({arg}={v!r}): {type(exc).__name__}: {exc}"[:200])
                finally:
                    signal.alarm(0)
    return found


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--examples", type=int, default=100,
                        help="draws per declared argument (0: only the timings)")
    parser.add_argument("-k", dest="select", default=None,
                        help="pytest -k expression selecting callables (e.g. 'circuits')")
    parser.add_argument("--extremes", action="store_true",
                        help="also call every declared real-number argument at valid extremes")
    args = parser.parse_args(argv)
    status = fuzz(args.examples, args.select) if args.examples > 0 else 0
    if args.extremes:
        found = extremes()
        print(f"extreme valid floats: {len(found)} calls failed other than by ValueError/"
              f"TypeError" + "".join(f"\n  {f}" for f in found))
        status = status or int(bool(found))
    print(f"\n{'call':40s} {'declared (us)':>14s} {'bare (us)':>10s} {'ratio':>7s}")
    for name, dec, raw in timings():
        print(f"{name:40s} {dec:14.1f} {raw:10.1f} {dec / raw:7.2f}")
    return status


if __name__ == "__main__":
    raise SystemExit(main())
