#!/usr/bin/env bash
# The paper-protocol runs still missing, cheapest first, one after another (each resumable:
# rerunning this script skips every finished unit under its --out folder).
# Start:  cd REPO && PYTHONPATH=$PWD nohup nice -n 10 bash results/paper-runs.sh > paper-runs.log 2>&1 &
# Results land in results/ (and results/t3/, results/angle-pi-over-2/, results/pyramid-seeds-3-4/,
# whose pyramid file merges with results/pyramid-shots-paper.json: qdensity results merge).
set -u
QD=${QD:-qdensity}
export QDENSITY_NUM_THREADS=1 OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 MKL_NUM_THREADS=1
run() {  # run NAME OUT [args...]
  local name=$1 out=$2; shift 2
  echo "=== $(date -u +%FT%TZ) start $name -> $out $*"
  $QD experiment "$name" --paper --cluster local:2 --out "$out" "$@"
  echo "=== $(date -u +%FT%TZ) end $name rc=$?"
}
# ~40 CPU s per seed: 8 seeds for the D = 1 non-inferiority and the depth trend
run orthoqnn-depth results --seeds 8
# ~90-200 CPU s per seed, both settings (Methods T_4, Supp. J T_2)
run reuploading results --seeds 6
# Supp. J's T_3 panel (Fig. 18), ~half a reuploading seed each
run reuploading results/t3 --seeds 14 --set setting='"t3"'
# ~700 CPU s per seed (3 families), 5 runs from one initialisation (Fig. 5), sum_i Z_i read-out;
# the adapted code's 0.5 x angle, then the Methods' pi x / 2
run equivariant results --seeds 5
run equivariant results/angle-pi-over-2 --seeds 5 --set angle_scale=1.5708
# pyramid-shots: seeds 3 and 4 beside the committed 0-2 (merge with `qdensity results merge`)
run pyramid-shots results/pyramid-seeds-3-4 --seeds 3,4
# the LCU / single sweep (10 units of 32 trials, 5 seeds)
run lcu-vs-single results --seeds 5
# moe: 3 seeds of one 32-trial study per model (33 units)
run moe results --seeds 3
echo "=== $(date -u +%FT%TZ) all done"
