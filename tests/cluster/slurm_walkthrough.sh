#!/usr/bin/env bash
# Runs the walkthrough of docs/cluster.md ("Slurm on one machine") literally: its sh block, taken
# from the doc, in a scratch copy of the source tree (build/, scripts/, configs/ linked), with a
# state directory of its own (CCFR_SLURM_DIR) and one CPU for the node. Checks that every cell
# completed after the cancel and the resume, that the resume submitted a second job, that the
# table was collected and that `scripts/slurm-local stop` left no daemon. Needs root.
#   slurm_walkthrough.sh CCFR_EXE SOURCE_DIR SCRATCH_DIR
set -uo pipefail
exe=$(realpath "$1") src=$(realpath "$2") scratch=$3
fail() { echo "slurm_walkthrough: FAIL: $*" >&2; exit 1; }

rm -rf "$scratch"
mkdir -p "$scratch/tree"
scratch=$(realpath "$scratch")
tree=$scratch/tree
ln -s "$(dirname "$(dirname "$exe")")" "$tree/build"
ln -s "$src/scripts" "$tree/scripts"
ln -s "$src/configs" "$tree/configs"
[ "$tree/build/apps/ccfr" -ef "$exe" ] || fail "$exe is not BUILD/apps/ccfr"

python3 - "$src/docs/cluster.md" "$scratch/walkthrough.sh" <<'PY' || fail "no walkthrough block in docs/cluster.md"
import sys
text = open(sys.argv[1], encoding="utf-8").read()
section = text.split("\n## Slurm on one machine\n", 1)[1]
block = section.split("\n```sh\n", 1)[1].split("\n```\n", 1)[0]
open(sys.argv[2], "w").write(block + "\n")
PY
export CCFR_SLURM_DIR
CCFR_SLURM_DIR=$(mktemp -u /tmp/ccfr-slurm-wt.XXXXXX)
export CCFR_SLURM_CPUS=1
trap '"$src/scripts/slurm-local" stop >/dev/null 2>&1' EXIT
echo "slurm_walkthrough: running docs/cluster.md's block ($(grep -c . "$scratch/walkthrough.sh") lines) in $tree"
t0=$(date +%s)
(cd "$tree" && env -u SLURM_CONF bash -e -o pipefail "$scratch/walkthrough.sh") >"$scratch/out.txt" 2>&1
rc=$?
cat "$scratch/out.txt"
[ $rc -eq 0 ] || fail "the walkthrough exited $rc (above)"
echo "slurm_walkthrough: the walkthrough took $(($(date +%s) - t0)) s"

out=$tree/out/slurm-local
grep -q "^4 cells: 4 completed$" "$scratch/out.txt" || fail "not every cell completed"
[ "$(grep -c '^4 cells: 4 completed$' "$scratch/out.txt")" -eq 1 ] || fail "every cell completed before the cancel"
jobs=$(python3 -c "import json,sys; print(len(json.load(open(sys.argv[1]))['slurm_jobs']))" "$out/sweep.json")
[ "$jobs" = 2 ] || fail "sweep.json records $jobs jobs, not the sweep's and the resume's"
[ "$(grep -c ',completed,' "$out/sweep.csv")" = 4 ] || fail "sweep.csv does not list 4 completed cells"
[ ! -e "$CCFR_SLURM_DIR" ] || fail "scripts/slurm-local stop left $CCFR_SLURM_DIR"
for pid in $(grep -oE '\(pid [0-9]+\)' "$scratch/out.txt" | grep -oE '[0-9]+'); do
  kill -0 "$pid" 2>/dev/null && fail "daemon $pid still runs after stop"
done
echo "slurm_walkthrough: PASS"
