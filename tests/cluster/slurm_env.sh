# A private single-node Slurm cluster (docs/cluster.md), for scripts that source this file:
#   source tests/cluster/slurm_env.sh
#   slurm_start || exit 1     # munged, slurmctld, slurmd as root; exports SLURM_CONF
#   trap slurm_stop EXIT      # stops the daemons by pid, removes the temporary directory
#   slurm_wait_queue JOB SECONDS
# The daemons live in a short /tmp path (a unix socket path is limited to 108 bytes). The node is
# sized from nproc (or $CCFR_SLURM_CPUS, to leave cores to others on a shared machine) and 80 % of
# the available memory of free. Messages start with $slurm_prefix (default "slurm").

slurm_prefix=${slurm_prefix:-slurm}
slurm_tmp=

slurm_say() { echo "$slurm_prefix: $*" >&2; }

# The daemons' logs, for a failure message.
slurm_logs() {
  for f in "$slurm_tmp"/munge/log "$slurm_tmp"/slurmctld.log "$slurm_tmp"/slurmd.log; do
    [ -f "$f" ] && { echo "--- $f"; tail -20 "$f"; }
  done >&2
}

# Starts the cluster and waits until its node is idle; returns 1, saying why, when it cannot.
slurm_start() {
  [ "$(id -u)" -eq 0 ] || { slurm_say "must run as root to start munged, slurmctld and slurmd (uid $(id -u))"; return 1; }
  local b
  for b in munged slurmctld slurmd sbatch squeue scancel sinfo; do
    command -v "$b" >/dev/null || { slurm_say "'$b' not found: install slurm-wlm and munge (scripts/install-deps)"; return 1; }
  done
  [ -r /etc/munge/munge.key ] || { slurm_say "/etc/munge/munge.key is missing (the munge package creates it)"; return 1; }
  slurm_tmp=$(mktemp -d /tmp/ccfr-slurm.XXXXXX) || { slurm_say "mktemp failed"; return 1; }
  mkdir -p "$slurm_tmp/state" "$slurm_tmp/spool" "$slurm_tmp/munge"
  chmod 700 "$slurm_tmp/munge"
  cp /etc/munge/munge.key "$slurm_tmp/munge/key" && chmod 600 "$slurm_tmp/munge/key"

  local host cpus mem t=$slurm_tmp
  host=$(hostname -s)
  cpus=${CCFR_SLURM_CPUS:-$(nproc)}
  mem=$(free -m | awk '/^Mem:/ {print int($7 * 0.8)}')
  cat > "$t/slurm.conf" <<CONF
ClusterName=ccfrtest
SlurmctldHost=$host
SlurmUser=root
SlurmdUser=root
SlurmctldPort=$(slurm_free_port)
SlurmdPort=$(slurm_free_port)
AuthType=auth/munge
AuthInfo=socket=$t/munge/sock
CredType=cred/munge
StateSaveLocation=$t/state
SlurmdSpoolDir=$t/spool
SlurmctldPidFile=$t/slurmctld.pid
SlurmdPidFile=$t/slurmd.pid
SlurmctldLogFile=$t/slurmctld.log
SlurmdLogFile=$t/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SchedulerType=sched/backfill
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
ReturnToService=2
MpiDefault=none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
JobCompType=jobcomp/none
KillWait=10
MinJobAge=600
NodeName=$host CPUs=$cpus RealMemory=$mem State=UNKNOWN
PartitionName=test Nodes=ALL Default=YES MaxTime=INFINITE State=UP
CONF
  export SLURM_CONF=$t/slurm.conf

  munged --force --socket="$t/munge/sock" --key-file="$t/munge/key" --pid-file="$t/munge/pid" \
    --log-file="$t/munge/log" --seed-file="$t/munge/seed" || { slurm_logs; slurm_say "munged did not start"; return 1; }
  slurmctld -f "$t/slurm.conf" || { slurm_logs; slurm_say "slurmctld did not start"; return 1; }
  slurmd -f "$t/slurm.conf" || { slurm_logs; slurm_say "slurmd did not start"; return 1; }
  local i state=
  for i in $(seq 60); do
    state=$(sinfo -h -o %T 2>/dev/null | head -1)
    [ "$state" = idle ] && break
    sleep 0.5
  done
  [ "$state" = idle ] || { slurm_logs; slurm_say "the node did not become idle within 30 s (sinfo says '$state')"; return 1; }
  slurm_say "cluster up: node $host, $cpus CPUs, $mem MB, daemons $(cat "$t/munge/pid") $(cat "$t/slurmctld.pid") $(cat "$t/slurmd.pid")"
}

# Cancels what is left, stops the daemons by pid (TERM, then KILL) and removes the directory.
slurm_stop() {
  [ -n "$slurm_tmp" ] || return 0
  local f
  [ -n "${SLURM_CONF:-}" ] && scancel --user=root >/dev/null 2>&1
  for f in "$slurm_tmp/slurmd.pid" "$slurm_tmp/slurmctld.pid" "$slurm_tmp/munge/pid"; do
    [ -s "$f" ] && kill "$(cat "$f")" 2>/dev/null
  done
  sleep 1
  for f in "$slurm_tmp/slurmd.pid" "$slurm_tmp/slurmctld.pid" "$slurm_tmp/munge/pid"; do
    [ -s "$f" ] && kill -9 "$(cat "$f")" 2>/dev/null
  done
  rm -rf "$slurm_tmp"
  slurm_tmp=
}

slurm_free_port() { python3 -c 'import socket; s=socket.socket(); s.bind(("127.0.0.1",0)); print(s.getsockname()[1])'; }

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
