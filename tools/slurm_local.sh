#!/usr/bin/env bash
# A one-node Slurm cluster on this machine, for the cluster tests and for
# trying `workbench ... --slurm` without a cluster (issue 31). As root.
#
#   bash tools/slurm_local.sh start [DIR]   munged, slurmctld and slurmd on localhost;
#                                           returns when sinfo says the node is idle
#   bash tools/slurm_local.sh stop [DIR]    stops the three daemons it started
#   bash tools/slurm_local.sh env [DIR]     prints `export SLURM_CONF=...` for the clients
#
# DIR (default /tmp/furn-slurm) holds slurm.conf, the daemons' state, logs
# and pid files. The node offers this machine's CPUs and memory; no cgroups,
# no accounting database (job state comes from squeue and the job folder);
# controller and node at 127.0.0.1, so the host name need not resolve.
set -euo pipefail

mode="${1:-}"
dir="${2:-${FURN_SLURM_DIR:-/tmp/furn-slurm}}"
conf="$dir/slurm.conf"

die() { echo "slurm_local: $*" >&2; exit 1; }

write_conf() {
  local host cpus memory
  host="$(hostname -s)"
  cpus="$(nproc)"
  memory="$(awk '/MemTotal/ { print int($2 / 1024 * 0.9) }' /proc/meminfo)"
  mkdir -p "$dir/state" "$dir/spool" "$dir/log"
  cat > "$conf" <<EOF
# Written by tools/slurm_local.sh: one node, this machine.
ClusterName=furn-local
SlurmctldHost=$host(127.0.0.1)
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
CredType=cred/munge
StateSaveLocation=$dir/state
SlurmdSpoolDir=$dir/spool
SlurmctldPidFile=$dir/slurmctld.pid
SlurmdPidFile=$dir/slurmd.pid
SlurmctldLogFile=$dir/log/slurmctld.log
SlurmdLogFile=$dir/log/slurmd.log
SlurmctldPort=6917
SlurmdPort=6918
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SelectType=select/cons_tres
SelectTypeParameters=CR_Core_Memory
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
JobCompType=jobcomp/none
MpiDefault=none
ReturnToService=2
MinJobAge=3600
SchedulerParameters=batch_sched_delay=0
DefMemPerCPU=2048
DependencyParameters=kill_invalid_depend
NodeName=$host NodeAddr=127.0.0.1 CPUs=$cpus RealMemory=$memory State=UNKNOWN
PartitionName=local Nodes=$host Default=YES MaxTime=INFINITE State=UP
EOF
}

start_munge() {
  if munge -n > /dev/null 2>&1; then return; fi
  [[ -f /etc/munge/munge.key ]] || die "no /etc/munge/munge.key (install the munge package)"
  mkdir -p /run/munge /var/log/munge /var/lib/munge
  chown munge:munge /run/munge /var/log/munge /var/lib/munge
  runuser -u munge -- /usr/sbin/munged
  touch "$dir/started-munged"
  for _ in $(seq 50); do munge -n > /dev/null 2>&1 && return; sleep 0.1; done
  die "munged did not start"
}

wait_idle() {
  local state=""
  for _ in $(seq 300); do
    state="$(SLURM_CONF="$conf" sinfo -h -o %t 2>/dev/null | head -1 || true)"
    [[ "$state" == idle ]] && return
    if [[ "$state" == down* || "$state" == drain* ]]; then
      SLURM_CONF="$conf" scontrol update nodename="$(hostname -s)" state=resume > /dev/null 2>&1 || true
    fi
    sleep 0.2
  done
  die "the node is '${state:-not listed}' after 60 s, not idle (logs: $dir/log)"
}

stop_daemons() {
  for daemon in slurmd slurmctld; do
    local pid_file="$dir/$daemon.pid"
    if [[ -f "$pid_file" ]]; then
      local pid
      pid="$(cat "$pid_file")"
      kill "$pid" 2> /dev/null || true
      for _ in $(seq 50); do kill -0 "$pid" 2> /dev/null || break; sleep 0.1; done
      rm -f "$pid_file"
    fi
  done
  if [[ -f "$dir/started-munged" ]]; then
    pkill -x munged 2> /dev/null || true
    rm -f "$dir/started-munged"
  fi
}

case "$mode" in
  start)
    [[ $(id -u) -eq 0 ]] || die "start needs root (the daemons run as root on a test node)"
    command -v slurmctld > /dev/null || die "slurmctld not found: bash tools/install_deps.sh"
    stop_daemons
    write_conf
    start_munge
    # -c: a clean start, no jobs kept from an earlier cluster in DIR.
    slurmctld -c -f "$conf"
    slurmd -f "$conf"
    wait_idle
    echo "slurm_local: node $(hostname -s) idle; export SLURM_CONF=$conf"
    ;;
  stop)
    stop_daemons
    echo "slurm_local: stopped"
    ;;
  env)
    echo "export SLURM_CONF=$conf"
    ;;
  *)
    echo "usage: bash tools/slurm_local.sh start|stop|env [DIR]" >&2
    exit 2
    ;;
esac
