"""Progress bars: drawn on a terminal (phase name, circuits, shots), silent when not a terminal
or when asked to be."""

import io

import numpy as np
import pytest
from qiskit.quantum_info import SparsePauliOp

from qdensity.progress import progress_bar, wait_for


class FakeTerminal(io.StringIO):
    def isatty(self) -> bool:
        return True


def test_bar_draws_only_on_a_terminal_and_when_verbose():
    for stream, verbose, draws in ((FakeTerminal(), True, True), (FakeTerminal(), False, False),
                                   (io.StringIO(), True, False)):
        with progress_bar(4, desc="phase", unit="circuit", verbose=verbose, file=stream,
                          leave=True) as bar:
            bar.update(4)
        assert ("phase" in stream.getvalue()) is draws
        assert ("4/4" in stream.getvalue()) is draws


def test_wait_for_polls_until_done_and_returns_the_result():
    class Job:
        polls = 0

        def done(self):
            self.polls += 1
            return self.polls > 2

        def result(self):
            return "bits"

    job, stream = Job(), FakeTerminal()
    with progress_bar(1, desc="sample", file=stream) as bar:
        assert wait_for(job, bar, poll=0.001) == "bits"
    assert job.polls == 3
    silent = Job()
    assert wait_for(silent, progress_bar(1, file=io.StringIO())) == "bits" and silent.polls == 0


def _plan():
    from qdensity.circuits.ansatze import round_robin
    from qdensity.execution.plans import expectation_plan

    qc = round_robin(3)
    qc.x(0)
    return expectation_plan(qc, SparsePauliOp("IIZ"), np.zeros((5, 3)), shots=100)


@pytest.mark.parametrize("progress", [True, False])
def test_sampler_engine_shows_one_bar_per_phase(monkeypatch, progress):
    from qdensity import SamplerEngine

    stream = FakeTerminal()
    monkeypatch.setattr("sys.stderr", stream)
    engine = SamplerEngine(seed=1, progress=progress)
    engine.progress_delay = 0.0
    value, _ = _plan().run(engine)
    assert np.allclose(value, -1.0)  # <Z_0> = -1 on |001> (zero-angle RBS gates)
    text = stream.getvalue()
    if progress:
        assert "transpile" in text and "1/1" in text
        assert "sample" in text and "5/5" in text and "shots=500" in text
    else:
        assert text == ""


def test_table1_bar_counts_rows(monkeypatch):
    from qdensity.gradients.table1 import table1

    stream = FakeTerminal()
    monkeypatch.setattr("sys.stderr", stream)
    rows = table1([4], ["pyramid", "round_robin"])
    assert len(rows) == 2 and "table1" in stream.getvalue() and "2/2" in stream.getvalue()
    stream.truncate(0)
    table1([4], ["pyramid"], verbose=False)
    assert stream.getvalue().strip("\x00") == ""
