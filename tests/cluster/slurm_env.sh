# A private single-node Slurm cluster for test scripts, started and stopped by scripts/slurm-local
# (the same command docs/cluster.md gives users), in a temporary state directory of its own:
#   source tests/cluster/slurm_env.sh
#   slurm_start || exit 1     # scripts/slurm-local start; exports SLURM_CONF
#   trap slurm_stop EXIT      # scripts/slurm-local stop: cancels, stops the daemons by pid, removes the directory
#   slurm_wait_queue JOB SECONDS
# CCFR_SLURM_CPUS=N gives the node N CPUs instead of nproc. Messages start with $slurm_prefix.

slurm_prefix=${slurm_prefix:-slurm}
slurm_tmp=
slurm_local="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)/scripts/slurm-local"

slurm_say() { echo "$slurm_prefix: $*" >&2; }
slurm_logs() { [ -n "$slurm_tmp" ] && slurm_prefix=$slurm_prefix "$slurm_local" --dir "$slurm_tmp" logs; }

# Starts the cluster and waits until its node is idle; returns 1, saying why, when it cannot.
slurm_start() {
  local line
  slurm_tmp=$(mktemp -u /tmp/ccfr-slurm.XXXXXX) || { slurm_say "mktemp failed"; return 1; }
  line=$(slurm_prefix=$slurm_prefix "$slurm_local" --dir "$slurm_tmp" start) || return 1
  [[ $line =~ ^export\ SLURM_CONF=(.+)$ ]] || { slurm_say "scripts/slurm-local start printed '$line'"; return 1; }
  export SLURM_CONF=${BASH_REMATCH[1]}
}

slurm_stop() {
  [ -n "$slurm_tmp" ] || return 0
  slurm_prefix=$slurm_prefix "$slurm_local" --dir "$slurm_tmp" stop
  slurm_tmp=
}

# Waits until JOB has left the queue; returns 1 (with the daemons' logs) after SECONDS (default 300).
slurm_wait_queue() {
  local i limit=${2:-300}
  for i in $(seq $((limit * 2))); do
    [ -z "$(squeue -h -j "$1" 2>/dev/null)" ] && return 0
    sleep 0.5
  done
  slurm_logs
  slurm_say "job $1 still queued after $limit s"
  return 1
}
