"""Run each statistical test over many seeds and print its failure count (not part of CI).

Usage: ``python benchmarks/fuzz_statistics.py [--seeds 50] [TEST_ID ...]`` from the repository
root. A statistical test reads its sampling seed from ``QDENSITY_STAT_SEED`` at call time (its
own fixed seed when unset) and states the probability with which it may fail for a random
seed; over ``S`` seeds the expected failure count is ``S`` times that rate, so a count well
above it means the bound in the test is wrong. The runs go one after another in this process
(single-threaded, so it can run beside other work).

Run ``k`` sets ``QDENSITY_STAT_SEED = k * SEED_STRIDE``, not ``k``: the count assumes
independent runs, and seeds one apart are not independent with noise. qiskit-aer (0.18.2)
simulates a noisy circuit as one trajectory per shot and seeds shot ``i`` with
``seed_simulator + i``, so seeds ``s`` and ``s + 1`` draw the same shots, shifted by one.
Measured: a 4-qubit GHZ-like circuit on ``get_target("heavy_hex", 4, seed=5)``, 2 rows of 2000
shots through ``sampler(seed=8, method="statevector")`` and ``seed=10`` (fuzz seeds 0 and 1 of
``test_estimates_agree_with_the_other_method_within_standard_errors``, which uses
``2 S + 8``): shot ``i + 2`` of the first equals shot ``i`` of the second in every row, all
1998 of them. Seeds ``SEED_STRIDE`` apart (more than the shots of any run here) shared no
shot at any shift. Noiseless sampling (one final state, one random stream) is not affected.
"""

from __future__ import annotations

import argparse
import contextlib
import os
import sys
import time

import pytest

#: Test id -> stated false-failure rate per run (see each test's comment).
STATISTICAL_TESTS: dict[str, float] = {
    "tests/gradients/test_commuting_gradients.py::test_sampled_gradients_within_standard_errors":
        3e-3,  # three cases, 1e-3 each
    "tests/execution/test_schedulers.py::test_unbiased_and_standard_error_calibrated":
        3e-3,  # three schedulers, 1e-3 each
    "tests/execution/test_schedulers.py::test_exact_variances_match_closed_forms": 1e-3,
    "tests/execution/test_schedulers.py::test_proportional_beats_per_shot_when_means_differ":
        1e-3,
    "tests/models/test_lcu_sampling.py::test_sampled_estimates_within_standard_errors": 2e-4,
    "tests/models/test_models.py::test_train_mode_samples_subunitaries_unbiased": 2e-4,
    "tests/models/test_models.py::test_eval_mode_samples_the_deterministic_state": 6e-5,
    "tests/gradients/test_shift.py::test_sampled_gradient_within_standard_errors": 1e-3,
    "tests/gradients/test_shift.py::"
    "test_sampled_unary_readout_gradient_reads_the_bits_never_a_dense_row": 6e-5,
    "tests/execution/test_independent_shots.py::test_aer_alone_correlates_shot_groups": 2e-4,
    "tests/execution/test_independent_shots.py::"
    "test_run_independent_decorrelates_and_keeps_order_and_seed": 2e-4,
    "tests/execution/test_independent_shots.py::"
    "test_sampler_engine_jobs_of_different_shots_are_independent": 1e-3,
    "tests/execution/test_independent_shots.py::test_stratified_spread_matches_its_standard_error":
        1e-3,
    "tests/execution/test_independent_shots.py::"
    "test_other_samplers_get_one_job_per_shot_count_in_order": 3e-4,
    "tests/execution/test_plans_engines.py::test_sampler_engine_within_standard_errors_and_ledger":
        3e-4,
    "tests/execution/test_plans_engines.py::"
    "test_sampler_engine_unparameterised_template_several_rows": 5e-4,
    "tests/execution/test_plans_engines.py::"
    "test_sampler_engine_template_whose_parameters_vanish_in_transpilation": 3e-4,
    "tests/execution/test_plans_engines.py::test_sampler_probabilities_plan_within_bounds": 1e-3,
    "tests/execution/test_sampler_contract.py::test_final_flip_samples_the_exact_distribution":
        2e-5,  # 32 outcomes at 5 standard errors
    "tests/execution/test_sampler_contract.py::"
    "test_fidelity_kernel_uncompute_ends_with_an_x_and_is_sampled": 6e-7,  # 5 standard errors
    "tests/execution/test_plans_engines.py::test_postselect_hamming_weight_on_noisy_unary_circuit":
        1e-5,
    "tests/learning/test_torch.py::test_sampled_input_gradients_within_standard_errors_and_counted":
        4e-4,
    "tests/learning/test_torch.py::test_sampled_gradients_agree_with_exact_within_standard_errors":
        1e-3,
    "tests/learning/test_training.py::test_sampled_step_is_unbiased_against_exact": 1e-6,
    "tests/hardware/test_runtime.py::test_density_gradient_plan_through_the_runtime_sampler":
        1e-4,
    "tests/hardware/test_runtime.py::test_forward_tomography_and_randomised_sampling_in_one_batch":
        3e-6,
    "tests/hardware/test_runtime.py::test_noisy_runtime_forward_is_close_but_biased_by_the_snapshot":
        1e-10,
    "tests/hardware/test_snapshots.py::test_manila_simulator_carries_the_calibrated_readout_error":
        1e-3,
    "tests/hardware/test_snapshots.py::test_snapshot_target_runs_density_sampling_and_gradient_plans":
        4e-6,
    "tests/hardware/test_mitigation.py::test_mitigation_alone_removes_the_readout_bias": 2e-6,
    "tests/hardware/test_served_noise.py::"
    "test_matrix_product_state_counts_follow_the_whole_models_law": 1e-4,
    "tests/hardware/test_mitigation.py::test_mitigated_and_postselected_beat_raw_over_seeds":
        1e-4,
    "tests/hardware/test_mitigation.py::test_density_model_output_from_mitigated_subunitaries":
        1e-6,
    "tests/hardware/test_mps_sampling.py::"
    "test_mps_sampled_outputs_and_gradients_at_30_qubits_match_the_unary_engine": 1.2e-4,
    "tests/hardware/test_mps_sampling.py::"
    "test_default_engine_picks_mps_for_unary_probabilities_at_32_qubits": 1e-3,  # 32 x 3e-5
    "tests/hardware/test_aer_sampling.py::"
    "test_estimates_agree_with_the_other_method_within_standard_errors": 4e-5,  # 2 methods
    "tests/hardware/test_aer_sampling.py::"
    "test_trajectories_at_few_shots_match_the_exact_noisy_distribution": 1e-4,
    "tests/hardware/test_aer_sampling.py::"
    "test_noisy_mps_on_its_relabelled_line_matches_the_exact_distribution": 1e-4,
    "tests/gradients/test_inputs.py::test_input_gradient_plan_exact_and_sampled": 8e-4,
    "tests/gradients/test_inputs.py::"
    "test_input_gradient_plan_on_unary_probabilities_exact_and_sampled": 5.5e-5,
    "tests/gradients/test_inputs.py::test_sampled_input_gradient_through_a_gated_mixture": 4.6e-6,
    "tests/learning/test_torch.py::"
    "test_sampled_unary_input_gradient_through_the_loader_and_a_torch_gate": 4.6e-6,
    "tests/learning/test_training.py::"
    "test_pre_layer_trains_on_a_sampler_with_sampled_input_gradients": 1.2e-5,
    "tests/execution/test_engine_mitigation.py::"
    "test_m3_removes_a_pure_readout_bias_within_its_standard_error": 2.5e-4,
    "tests/execution/test_engine_mitigation.py::test_gradient_plans_use_the_engine_mitigation":
        1e-3,
    "tests/execution/test_mitigated_errors.py::"
    "test_mitigated_expectation_error_matches_the_spread_over_seeds": 1e-3,
    "tests/execution/test_mitigated_errors.py::test_engine_m3_error_matches_the_spread_over_seeds":
        1e-3,
    "tests/execution/test_mitigated_errors.py::"
    "test_engine_m3_unary_output_error_matches_the_spread_over_seeds": 1e-3,
    "tests/execution/test_mitigated_errors.py::test_sample_m3_error_matches_the_spread_over_seeds":
        5e-4,
    "tests/execution/test_mitigated_errors.py::"
    "test_wide_register_m3_error_matches_the_spread_over_seeds": 2.5e-4,
}


#: Distance between the ``QDENSITY_STAT_SEED`` values of consecutive runs (see the module).
SEED_STRIDE = 100_003


def _run(test: str, seed: int) -> bool:
    """One run of ``test`` with ``QDENSITY_STAT_SEED=seed``, in this process (the tests read
    the variable at call time; importing Qiskit once, not once per seed)."""
    os.environ["QDENSITY_STAT_SEED"] = str(seed)
    with open(os.devnull, "w") as null, contextlib.redirect_stdout(null):
        code = pytest.main(["-q", "-p", "no:randomly", "-p", "no:cacheprovider", test])
    return code == 0


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=50,
                        help="runs per test (QDENSITY_STAT_SEED = k * SEED_STRIDE, k < S)")
    parser.add_argument("tests", nargs="*", help="test ids (default: every statistical test)")
    args = parser.parse_args(argv)
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    sys.path.insert(0, os.getcwd())
    tests = args.tests or list(STATISTICAL_TESTS)
    print(f"{'test':<90}{'failed':>8}{'expected':>10}{'seconds':>9}")
    worst = 0.0
    for test in tests:
        t0 = time.perf_counter()
        failed = [s for s in range(0, args.seeds * SEED_STRIDE, SEED_STRIDE)
                  if not _run(test, s)]
        expected = args.seeds * STATISTICAL_TESTS.get(test, 0.0)
        print(f"{test:<90}{len(failed):>8}{expected:>10.2f}{time.perf_counter() - t0:>9.0f}"
              + (f"  seeds {failed}" if failed else ""))
        worst = max(worst, len(failed) - expected)
    return 0 if worst < 1 else 1


if __name__ == "__main__":
    raise SystemExit(main())
