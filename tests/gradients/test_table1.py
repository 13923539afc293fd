"""Table 1 of the paper: gradient-circuit counts of pure and density models, against the
counts the paper states."""

import numpy as np
import pytest

from qdensity.gradients.table1 import table1_row


@pytest.mark.parametrize("n", [4, 6, 8])
def test_table1_exact_statements(n):
    rr = table1_row("round_robin", n)
    assert rr["original"]["gradient_circuits"] == 4 * n * (n - 1) // 2
    assert rr["density"]["gradient_circuits"] == n - 1
    assert rr["original"]["params"] == rr["density"]["params"] == n * (n - 1) // 2
    py = table1_row("pyramid", n)
    assert py["density"]["gradient_circuits"] == 2
    assert py["original"]["gradient_circuits"] == 4 * n * (n - 1) // 2
    he = table1_row("hardware_efficient", n, layers=3)
    assert he["original"]["gradient_circuits"] == 2 * n * 3
    assert he["density"]["gradient_circuits"] == 3  # does not grow with n
    eq = table1_row("equivariant_xx", n, copies_k=3)
    assert eq["original"]["gradient_circuits"] == 1
    assert eq["density"]["gradient_circuits"] == 3
    if n & (n - 1) == 0:
        bf = table1_row("butterfly", n)
        assert bf["density"]["gradient_circuits"] == int(np.log2(n))
        assert bf["original"]["gradient_circuits"] == 4 * (n // 2) * int(np.log2(n))


def test_table1_row_restores_the_garbage_collector_and_names_bad_ansatze():
    import gc

    assert gc.isenabled()
    table1_row("butterfly", 4)
    assert gc.isenabled()
    gc.disable()
    try:
        table1_row("butterfly", 4)
        assert not gc.isenabled()  # left as it was found
    finally:
        gc.enable()
    with pytest.raises(ValueError, match="ansatz must be one of"):
        table1_row("brickwork", 4)
    assert gc.isenabled()


def test_compressed_pyramid_has_n_minus_1_parameters():
    # the paper's O(n) density-pyramid parameters hold for the compressed version: one angle per
    # neighbouring pair, n - 1; the uncompressed odd-even split keeps all n (n - 1) / 2
    from qdensity.gradients.table1 import format_table1, table1_row

    for n in (4, 6, 8):
        row = table1_row("pyramid", n)
        assert row["density"]["params"] == n * (n - 1) // 2
        assert row["compressed"]["params"] == n - 1
        assert row["compressed"]["gradient_circuits"] == 2  # one commuting circuit per half
    assert table1_row("butterfly", 4)["compressed"] is None
    text = format_table1([table1_row("pyramid", 8), table1_row("butterfly", 8)])
    assert "compressed density" in text and text.splitlines()[-1].rstrip().endswith("-")
