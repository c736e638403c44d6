#!/usr/bin/env bash
# A single-node Slurm on the loopback interface, for the batch tests and for trying
# `meshmux batch --slurm` on one machine. Everything lives in one temporary folder: munged with
# its own key and socket, slurmctld and slurmd in the foreground (-D) as background processes
# of this script, free ports chosen at start, no accounting, no cgroups.
#
#   eval "$(scripts/slurm-local.sh start)"   # starts it; prints the exports (SLURM_CONF,
#                                            # MESHMUX_SLURM_DIR) for the calling shell
#   sbatch / squeue / scontrol ...           # talk to it through SLURM_CONF
#   scripts/slurm-local.sh stop [DIR]        # stops the daemons, removes the folder
#   scripts/slurm-local.sh status [DIR]      # sinfo of the running cluster
#
# start exits 77 (the tests' skip code) with the reason on stderr when Slurm or munge is not
# installed (Debian: slurm-wlm munge; scripts/setup.sh installs them), 1 when a daemon fails
# to come up (its log is printed). Needs no root: the daemons run as the calling user.
set -euo pipefail

die() {
  echo "slurm-local: $*" >&2
  exit 1
}

# A TCP port on 127.0.0.1 that nothing listens on (bash's /dev/tcp connect fails).
free_port() {
  local p
  for _ in $(seq 1 200); do
    p=$((20000 + RANDOM % 40000))
    if ! (exec 3<>"/dev/tcp/127.0.0.1/$p") 2>/dev/null; then
      echo "$p"
      return 0
    fi
  done
  die "no free TCP port found on 127.0.0.1"
}

# Waits up to $2 seconds for command $1 to succeed.
wait_for() {
  local cmd=$1 limit=$2 t=0
  while ! eval "$cmd" >/dev/null 2>&1; do
    sleep 0.1
    t=$((t + 1))
    [ "$t" -lt $((limit * 10)) ] || return 1
  done
}

start() {
  local missing=()
  for b in munged slurmctld slurmd sbatch scontrol; do
    command -v "$b" >/dev/null 2>&1 || [ -x "/usr/sbin/$b" ] || missing+=("$b")
  done
  if [ ${#missing[@]} -gt 0 ]; then
    echo "slurm-local: not installed here (${missing[*]} missing; Debian packages slurm-wlm munge)" >&2
    exit 77
  fi
  export PATH="$PATH:/usr/sbin"
  local dir
  dir=$(mktemp -d "${TMPDIR:-/tmp}/meshmux-slurm.XXXXXX")
  chmod 700 "$dir"
  mkdir -p "$dir/munge" "$dir/state" "$dir/spool" "$dir/log"
  chmod 700 "$dir/munge"
  # munge: its own key (1 KiB of random bytes, readable by its owner only) and socket.
  head -c 1024 /dev/urandom >"$dir/munge/munge.key"
  chmod 400 "$dir/munge/munge.key"
  local sock="$dir/munge/munge.socket"
  munged --foreground --force --socket="$sock" --key-file="$dir/munge/munge.key" \
    --pid-file="$dir/munge/munged.pid" --log-file="$dir/log/munged.log" \
    --seed-file="$dir/munge/munged.seed" >"$dir/log/munged.out" 2>&1 &
  echo $! >"$dir/munged.pid"
  if ! wait_for "[ -S '$sock' ]" 10; then
    cat "$dir/log/munged.out" "$dir/log/munged.log" >&2 2>/dev/null || true
    stop "$dir"
    die "munged did not start"
  fi

  local user ctld_port d_port cpus mem
  user=$(id -un)
  ctld_port=$(free_port)
  d_port=$(free_port)
  while [ "$d_port" = "$ctld_port" ]; do d_port=$(free_port); done
  cpus=$(nproc)
  mem=$(($(awk '/MemTotal/ {print $2}' /proc/meminfo) / 1024 * 9 / 10))
  cat >"$dir/slurm.conf" <<EOF
# Written by scripts/slurm-local.sh: one node on loopback, no accounting.
ClusterName=meshmux-local
SlurmctldHost=localhost(127.0.0.1)
SlurmctldPort=$ctld_port
SlurmdPort=$d_port
SlurmUser=$user
SlurmdUser=$user
AuthType=auth/munge
CredType=cred/munge
AuthInfo=socket=$sock
CommunicationParameters=NoInAddrAny,NoCtldInAddrAny
StateSaveLocation=$dir/state
SlurmdSpoolDir=$dir/spool
SlurmctldPidFile=$dir/slurmctld.pidfile
SlurmdPidFile=$dir/slurmd.pidfile
SlurmctldLogFile=$dir/log/slurmctld.log
SlurmdLogFile=$dir/log/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
JobCompType=jobcomp/none
MpiDefault=none
SchedulerType=sched/backfill
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
ReturnToService=2
MinJobAge=3600
SlurmdTimeout=30
InactiveLimit=0
KillWait=5
NodeName=localhost NodeAddr=127.0.0.1 CPUs=$cpus RealMemory=$mem State=UNKNOWN
PartitionName=local Nodes=localhost Default=YES MaxTime=INFINITE State=UP
EOF
  export SLURM_CONF="$dir/slurm.conf"
  slurmctld -D -i -f "$SLURM_CONF" >"$dir/log/slurmctld.out" 2>&1 &
  echo $! >"$dir/slurmctld.pid"
  slurmd -D -N localhost -f "$SLURM_CONF" >"$dir/log/slurmd.out" 2>&1 &
  echo $! >"$dir/slurmd.pid"
  # Up when the node is idle (slurmd registered with slurmctld).
  if ! wait_for "sinfo -h -N -o '%T' | grep -qx idle" 30; then
    for f in slurmctld.out slurmctld.log slurmd.out slurmd.log; do
      echo "--- $f" >&2
      tail -n 20 "$dir/log/$f" >&2 2>/dev/null || true
    done
    stop "$dir"
    die "slurmctld/slurmd did not come up"
  fi
  echo "export SLURM_CONF='$SLURM_CONF'"
  echo "export MESHMUX_SLURM_DIR='$dir'"
  echo "slurm-local: running in $dir (slurmctld on 127.0.0.1:$ctld_port, slurmd on :$d_port)" >&2
}

stop() {
  local dir=${1:-${MESHMUX_SLURM_DIR:-}}
  [ -n "$dir" ] || die "stop: which folder? (give it, or set MESHMUX_SLURM_DIR)"
  [ -d "$dir" ] || return 0
  case "$dir" in */meshmux-slurm.*) ;; *) die "stop: $dir is not a slurm-local folder" ;; esac
  local pids=()
  for d in slurmd slurmctld munged; do
    [ -f "$dir/$d.pid" ] && pids+=("$(cat "$dir/$d.pid")")
  done
  # The jobs first (their slurmstepd are not slurmd's children), then the daemons; TERM, then
  # KILL after 5 s.
  if [ -f "$dir/slurm.conf" ]; then
    export SLURM_CONF="$dir/slurm.conf" PATH="$PATH:/usr/sbin"
    scancel --full --quiet --user="$(id -un)" 2>/dev/null || true
    wait_for "[ -z \"\$(squeue -h -o %i 2>/dev/null)\" ]" 10 || true
  fi
  for p in "${pids[@]}"; do kill -TERM "$p" 2>/dev/null || true; done
  for _ in $(seq 1 50); do
    local alive=0
    for p in "${pids[@]}"; do kill -0 "$p" 2>/dev/null && alive=1; done
    [ "$alive" = 0 ] && break
    sleep 0.1
  done
  for p in "${pids[@]}"; do kill -KILL "$p" 2>/dev/null || true; done
  rm -rf "$dir"
}

case "${1:-}" in
  start) start ;;
  stop) stop "${2:-}" ;;
  status)
    dir=${2:-${MESHMUX_SLURM_DIR:-}}
    SLURM_CONF="$dir/slurm.conf" sinfo
    ;;
  *)
    sed -n '2,15p' "$0" | sed 's/^# \{0,1\}//' >&2
    exit 1
    ;;
esac
