#!/usr/bin/env bash
# The GPU measurement of issue 36 in one script: install the carried wheels (offline), time the
# torch engines against the CPU cores and JAX (benchmarks/bench_gpu.py), then one --full
# experiment on local:1, local:4 and local:16 (benchmarks/bench_cluster.py).
#
# Usage (from anywhere; runs in the repository root):
#
#   bash benchmarks/gpu_run.sh [all|install|gpu|cluster|wheels]
#
#   wheels   on a machine WITH network: download the wheels qdensity needs beyond what the GPU
#            machine has (qiskit, qiskit-aer, distributed, ...) into $WHEELS for Python
#            $WHEELS_PY (default 3.12), manylinux x86_64, minus $SKIP_WHEELS (default numpy,
#            scipy, numba, llvmlite, jax: the GPU machine has them); carry that folder
#            (<= 64 MiB with the repository).
#   install  pip install --no-index --find-links $WHEELS (nothing from the network), then
#            check that qdensity imports and torch sees the GPU.
#   gpu      bench_gpu.py -> $RESULTS/bench_gpu.json (+ .txt)
#   cluster  bench_cluster.py, $EXPERIMENT --full, $SEEDS seeds, local:1,local:4,local:16
#            -> $RESULTS/bench_cluster.json (+ .txt); one thread per worker (OMP, BLAS, numba
#            and qdensity's own threads set to 1), so N workers use N cores.
#   all      install, gpu, cluster.
#
# Environment: WHEELS (default wheels), RESULTS (default $OUT if set, else results/gpu),
# PYTHON (default python3), EXPERIMENT (default orthoqnn-depth: 6 units per seed), SEEDS
# (default 8: 48 units), MODE (default full), CONFIGS (default local:1,local:4,local:16),
# BENCH_GPU_ARGS (arguments of bench_gpu.py; default "--deadline 300").
#
# Timing: install well under a minute; gpu about 5 minutes (its --deadline); cluster about
# 4-6 minutes (local:1 runs the 48 units one after another). A caller with a 10-minute limit
# per command runs "install && gpu" in one call and "cluster" in the next.
set -euo pipefail
cd "$(dirname "$0")/.."
STAGE=${1:-all}
PYTHON=${PYTHON:-python3}
WHEELS=${WHEELS:-wheels}
RESULTS=${RESULTS:-${OUT:-results/gpu}}
EXPERIMENT=${EXPERIMENT:-orthoqnn-depth}
SEEDS=${SEEDS:-8}
CONFIGS=${CONFIGS:-local:1,local:4,local:16}
export PYTHONPATH="$PWD${PYTHONPATH:+:$PYTHONPATH}"
# what the GPU machine lacks (issue 36: it has torch, jax, cupy, numba-cuda, no qiskit)
NEEDED="qiskit qiskit-aer numba scipy scikit-learn matplotlib tqdm distributed"

wheels() {
    mkdir -p "$WHEELS"
    # shellcheck disable=SC2086
    "$PYTHON" -m pip download --only-binary=:all: --python-version "${WHEELS_PY:-3.12}" \
        --platform manylinux2014_x86_64 --platform manylinux_2_17_x86_64 \
        --platform manylinux_2_28_x86_64 -d "$WHEELS" $NEEDED
    # what the GPU machine has already (torch, jax and numba-cuda bring these): dropped to keep
    # the folder under the 64 MiB that may be carried
    for skip in ${SKIP_WHEELS:-numpy scipy llvmlite numba jax jaxlib ml_dtypes opt_einsum}; do
        rm -f "$WHEELS/$skip"-[0-9]*.whl
    done
    du -sh "$WHEELS"
}

install() {
    # the packages qdensity needs, from the folder; what is installed already and satisfies
    # them stays (numpy, scipy, numba of the GPU machine are not replaced)
    if compgen -G "$WHEELS/*.whl" > /dev/null; then
        # shellcheck disable=SC2086
        "$PYTHON" -m pip install --no-index --find-links "$WHEELS" $NEEDED
    else
        echo "no wheels in $WHEELS: using what is installed"
    fi
    "$PYTHON" - <<'EOF'
import qdensity, torch
print("qdensity", qdensity.__version__, "| torch", torch.__version__, "| cuda",
      torch.cuda.is_available(), torch.cuda.device_count(),
      torch.cuda.get_device_name(0) if torch.cuda.is_available() else "")
EOF
}

gpu() {
    mkdir -p "$RESULTS"
    # shellcheck disable=SC2086
    "$PYTHON" benchmarks/bench_gpu.py --out "$RESULTS/bench_gpu.json" \
        ${BENCH_GPU_ARGS:---deadline 300} \
        | tee "$RESULTS/bench_gpu.txt"
}

cluster() {
    mkdir -p "$RESULTS"
    OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 MKL_NUM_THREADS=1 NUMBA_NUM_THREADS=1 \
        QDENSITY_NUM_THREADS=1 \
        "$PYTHON" benchmarks/bench_cluster.py --experiment "$EXPERIMENT" --mode "${MODE:-full}" \
        --seeds "$SEEDS" --configs "$CONFIGS" --json "$RESULTS/bench_cluster.json" \
        | tee "$RESULTS/bench_cluster.txt"
}

case "$STAGE" in
    wheels) wheels ;;
    install) install ;;
    gpu) gpu ;;
    cluster) cluster ;;
    all) install; gpu; cluster ;;
    *) echo "unknown stage $STAGE (all, install, gpu, cluster, wheels)" >&2; exit 2 ;;
esac
