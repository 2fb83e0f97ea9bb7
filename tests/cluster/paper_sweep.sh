#!/usr/bin/env bash
# The paper sweep run twice, here and on a private single-node Slurm cluster (slurm_env.sh), and
# the two collected tables compared with scripts/compare-sweeps.py (timing columns left out; runs
# are deterministic, so everything else must be identical), and every frame file byte for byte.
# docs/cluster.md reports its result.
#   paper_sweep.sh CCFR_EXE SOURCE_DIR OUT_DIR [SPEC]    (SPEC: configs/sweeps/paper_smoke.yaml)
# Both sweeps run at once, each one cell at a time with one thread (the cluster's node gets
# $CCFR_SLURM_CPUS=1 CPU), so that they use two cores between them. Needs root (slurm_env.sh).
set -uo pipefail
exe=$(realpath "$1") src=$(realpath "$2") out=$3
spec=$(realpath "${4:-$src/configs/sweeps/paper_smoke.yaml}")
fail() { echo "paper_sweep: FAIL: $*" >&2; exit 1; }
[ -e "$out/local" ] || [ -e "$out/slurm" ] && fail "$out already holds a sweep; choose another OUT_DIR"
mkdir -p "$out"
out=$(realpath "$out")
slurm_prefix=paper_sweep
source "$(dirname "${BASH_SOURCE[0]}")/slurm_env.sh"
trap slurm_stop EXIT
CCFR_SLURM_CPUS=${CCFR_SLURM_CPUS:-1} slurm_start || fail "the test cluster did not start (above)"
echo "paper_sweep: $("$exe" --version), spec $spec, $(nproc) CPUs, load $(cut -d' ' -f1-3 /proc/loadavg)"

t0=$(date +%s)
( "$exe" sweep "$spec" --out "$out/local" --jobs 1 --threads 1 2>"$out/local.log"
  echo $? >"$out/local.rc"; echo $(($(date +%s) - t0)) >"$out/local.seconds" ) &
local_pid=$!
"$exe" sweep "$spec" --out "$out/slurm" --backend slurm --cpus-per-task 1 2>&1 | tee "$out/submit.log"
job=$(python3 -c "import json,sys; print(json.load(open(sys.argv[1]))['slurm_jobs'][-1]['job_id'])" \
  "$out/slurm/sweep.json") || fail "no job submitted"
slurm_wait_queue "$job" $((6 * 3600)) || fail "the cluster's sweep did not finish"
echo $(($(date +%s) - t0)) >"$out/slurm.seconds"
wait "$local_pid"
echo "paper_sweep: local sweep: exit $(cat "$out/local.rc") in $(cat "$out/local.seconds") s; cluster: $(cat "$out/slurm.seconds") s"

"$exe" sweep status "$out/slurm" >"$out/slurm_status.txt"
tail -1 "$out/slurm_status.txt"
# collect exits 1 when a cell fails its audit, which the baselines are expected to.
"$exe" sweep collect "$out/local" --no-plot >"$out/local_table.md"
"$exe" sweep collect "$out/slurm" --no-plot >"$out/slurm_table.md"
python3 "$src/scripts/compare-sweeps.py" "$out/local/sweep.csv" "$out/slurm/sweep.csv" ||
  fail "the cluster's table differs from the local one"
# And every frame file, byte for byte.
files=0
for d in "$out"/local/*/frames; do
  cell=$(basename "$(dirname "$d")")
  for f in "$d"/*; do
    files=$((files + 1))
    cmp -s "$f" "$out/slurm/$cell/frames/${f##*/}" || fail "$cell/frames/${f##*/} differs between the two sweeps"
  done
  [ "$(ls "$d" | wc -l)" -eq "$(ls "$out/slurm/$cell/frames" | wc -l)" ] || fail "$cell: other frame files on the cluster"
done
echo "paper_sweep: $files frame files identical"
echo "paper_sweep: PASS"
