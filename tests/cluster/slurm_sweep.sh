#!/usr/bin/env bash
# A real single-node Slurm cluster in a test (docs/cluster.md): starts munged, slurmctld and slurmd
# as root from a private slurm.conf in a temporary directory (the node sized from nproc and free),
# runs a sweep of 2 scenes x 3 solvers x 2 offsets on it, scancels one cell mid-run, resumes it
# with `ccfr sweep resume`, and checks that every cell passes its audit and that the collected
# table, every frame and every stats row (timing aside) equal the same sweep run locally.
# Stops its own daemons by pid. Fails, saying why, where the daemons cannot start.
#   slurm_sweep.sh CCFR_EXE SOURCE_DIR SCRATCH_DIR
set -uo pipefail
exe=$1 src=$2 scratch=$3
fail() { echo "slurm_sweep: FAIL: $*" >&2; exit 1; }

# The daemons live in a short /tmp path (slurm_env.sh); the runs in scratch.
rm -rf "$scratch"
mkdir -p "$scratch"
slurm_prefix=slurm_sweep
source "$(dirname "${BASH_SOURCE[0]}")/slurm_env.sh"
trap slurm_stop EXIT
slurm_start || fail "the test cluster did not start (above)"

cat > "$scratch/spec.yaml" <<EOF
configs: [$src/configs/two_sheets.yaml, $src/configs/stress/cloth_near_floor.yaml]
solvers: [ccfr, exact_projection, post_process]
parameters:
  contact.offset: [0.008, 0.01]
frames: 12
set: {output.checkpoint_every: 1, contact.on_violation: warn, time.frames: 12}
resources: {cpus_per_task: 1, time: "00:10:00", memory: "1G"}
EOF

# The reference: the same sweep run here.
"$exe" sweep "$scratch/spec.yaml" --out "$scratch/local" --jobs 2 2>"$scratch/local.log" || { tail "$scratch/local.log"; fail "local sweep failed"; }

# On the cluster; one cell is cancelled once it has a checkpoint.
# The victim is a cell that starts only after others finished; its id is the local sweep's (the
# same spec gives the same cells), read before submitting so that nothing slow runs in between.
victim_index=5
victim=$(python3 -c "import json,sys; print(json.load(open(sys.argv[1]))['cells'][int(sys.argv[2])]['id'])" "$scratch/local/sweep.json" $victim_index)
submit=$("$exe" sweep "$scratch/spec.yaml" --out "$scratch/slurm" --backend slurm 2>&1) || { echo "$submit"; slurm_logs; fail "ccfr sweep --backend slurm failed"; }
echo "$submit"
[[ $submit =~ submitted\ job\ ([0-9]+) ]] || fail "no job id in the output of ccfr sweep --backend slurm"
job=${BASH_REMATCH[1]}
# Only the newest checkpoint is kept: wait for any of frame 2 or later.
seen=
for i in $(seq 3000); do
  for f in "$scratch/slurm/$victim"/checkpoints/checkpoint_*.ccfr; do
    n=${f##*_}
    n=${n%.ccfr}
    [[ $n =~ ^[0-9]+$ ]] && [ $((10#$n)) -ge 2 ] && seen=$f
  done
  [ -n "$seen" ] && break
  sleep 0.02
done
[ -n "$seen" ] || fail "the cell $victim wrote no checkpoint of frame 2 or later"
scancel "${job}_${victim_index}" || fail "scancel ${job}_${victim_index} failed"
echo "slurm_sweep: $(date +%T.%N) saw $(basename "$seen"); cancelled ${job}_${victim_index} ($victim)"
wait_queue() { slurm_wait_queue "$1" 300 || fail "job $1 did not finish"; }
wait_queue "$job"
"$exe" sweep status "$scratch/slurm" | tee "$scratch/status1.txt"
grep -E "^$victim +(terminated|cancelled)" "$scratch/status1.txt" >/dev/null ||
  fail "the cancelled cell $victim is not reported terminated/cancelled (did it finish before scancel?)"
frames_at_cancel=$(grep -c . "$scratch/slurm/$victim/stats.csv")
[ "$frames_at_cancel" -lt 13 ] || fail "the cancelled cell has all its frames: scancel came too late to test anything"

"$exe" sweep resume "$scratch/slurm" || fail "ccfr sweep resume failed"
job2=$(python3 -c "import json,sys; print(json.load(open(sys.argv[1]))['slurm_jobs'][-1]['job_id'])" "$scratch/slurm/sweep.json")
[ "$job2" != "$job" ] || fail "ccfr sweep resume submitted no job"
wait_queue "$job2"
"$exe" sweep status "$scratch/slurm" | tee "$scratch/status2.txt"
grep -q "^12 cells: 12 completed$" "$scratch/status2.txt" || fail "not every cell completed after the resume"
grep -q '"after_frame"' "$scratch/slurm/$victim/run.json" || fail "$victim did not resume from its checkpoint"

# collect exits 1 when a cell fails its audit, which the baseline post_process may (checked below).
"$exe" sweep collect "$scratch/local" --no-plot > /dev/null
"$exe" sweep collect "$scratch/slurm" --no-plot > "$scratch/slurm_table.md"

python3 - "$scratch" <<'EOF' || fail "the cluster's results differ from the local ones"
import csv, os, sys
root = sys.argv[1]
timing = {"avg_frame_s", "max_frame_s", "median_frame_s", "xpbd_s", "broad_s", "narrow_s", "resolution_s",
          "wall_s", "cpu_s", "cpu_frame_s", "audit_s", "check_s"}
def table(path):
    with open(path) as f:
        # Every column in seconds is a clock reading (the stages' times and their serial parts).
        return [{k: v for k, v in row.items() if k not in timing and not k.endswith("_s")}
                for row in csv.DictReader(f)]
a, b = table(os.path.join(root, "local", "sweep.csv")), table(os.path.join(root, "slurm", "sweep.csv"))
assert len(a) == 12 and a == b, "sweep.csv differs"
assert all(r["status"] == "completed" and r["frames"] == "12" and r["audit"] in ("pass", "fail") for r in b), "status"
# The solvers with the guarantee must pass the exact audit in every cell.
assert all(r["audit"] == "pass" for r in b if r["solver"] in ("ccfr", "exact_projection")), "audit"
for r in a:
    for sub in ("frames",):
        da, db = (os.path.join(root, s, r["cell"], sub) for s in ("local", "slurm"))
        names = sorted(os.listdir(da))
        assert names == sorted(os.listdir(db)) and len(names) == 13, r["cell"]
        for n in names:
            assert open(os.path.join(da, n), "rb").read() == open(os.path.join(db, n), "rb").read(), (r["cell"], n)
    sa, sb = (table(os.path.join(root, s, r["cell"], "stats.csv")) for s in ("local", "slurm"))
    assert sa == sb and len(sa) == 12, ("stats", r["cell"])
print("slurm_sweep: 12 cells identical to the local sweep (frames, stats, table)")
EOF
cat "$scratch/slurm_table.md"
echo "slurm_sweep: PASS"
