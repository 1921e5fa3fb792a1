#!/usr/bin/env bash
# A one-machine Slurm cluster for tests/tests/slurm.rs (run as root):
#   cluster.sh install       Debian's slurm-wlm and munge, once (idempotent; no daemon is started
#                            by the packages: a policy-rc.d refuses it during the installation)
#   cluster.sh up DIR        a generated configuration under DIR (munge key, slurm.conf with
#                            this host as the controller and the only node, state, spool, logs)
#                            and munged, slurmctld and slurmd started on it; prints SLURM_CONF
#   cluster.sh down DIR      stops the three daemons (by the pids in DIR) and removes DIR
# Nothing outside DIR is written after the installation; the system's own /etc/slurm and
# /etc/munge are not used.
set -euo pipefail
cmd="${1:?install|up DIR|down DIR}"
dir="${2:-}"

case "$cmd" in
install)
  if command -v slurmctld >/dev/null && command -v slurmd >/dev/null &&
    command -v sbatch >/dev/null && command -v munged >/dev/null; then
    exit 0
  fi
  export DEBIAN_FRONTEND=noninteractive
  policy=/usr/sbin/policy-rc.d
  made=""
  if [ ! -e "$policy" ]; then
    printf '#!/bin/sh\nexit 101\n' >"$policy"
    chmod +x "$policy"
    made=1
  fi
  apt-get update -qq
  apt-get install -y -qq --no-install-recommends slurm-wlm munge >/dev/null
  if [ -n "$made" ]; then rm -f "$policy"; fi
  ;;
up)
  mkdir -p "$dir/state" "$dir/spool" "$dir/log"
  host="$(hostname -s)"
  cpus="$(nproc)"
  mem="$(awk '/MemTotal/ {print int($2 / 1024 * 0.8)}' /proc/meminfo)"
  # Ports of our own, away from a system Slurm's 6817/6818.
  base=$((20000 + $$ % 20000))
  head -c 1024 /dev/urandom >"$dir/munge.key"
  chmod 400 "$dir/munge.key"
  munged --force --key-file="$dir/munge.key" --socket="$dir/munge.socket" \
    --pid-file="$dir/munged.pid" --log-file="$dir/log/munged.log" --seed-file="$dir/munge.seed"
  cat >"$dir/slurm.conf" <<CONF
ClusterName=waggletest
SlurmctldHost=$host
SlurmctldPort=$base
SlurmdPort=$((base + 1))
AuthType=auth/munge
CredType=cred/munge
AuthInfo=socket=$dir/munge.socket
SlurmUser=root
SlurmdUser=root
StateSaveLocation=$dir/state
SlurmdSpoolDir=$dir/spool
SlurmctldPidFile=$dir/slurmctld.pid
SlurmdPidFile=$dir/slurmd.pid
SlurmctldLogFile=$dir/log/slurmctld.log
SlurmdLogFile=$dir/log/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
JobCompType=jobcomp/none
MpiDefault=none
SwitchType=switch/none
SchedulerType=sched/backfill
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
ReturnToService=2
MaxArraySize=1000
NodeName=$host CPUs=$cpus RealMemory=$mem State=UNKNOWN
PartitionName=waggle Nodes=$host Default=YES MaxTime=INFINITE State=UP
CONF
  export SLURM_CONF="$dir/slurm.conf"
  slurmctld -i -f "$SLURM_CONF"
  slurmd -f "$SLURM_CONF" -N "$host"
  for _ in $(seq 1 100); do
    if sinfo -h -o %T 2>/dev/null | grep -q idle; then
      echo "$SLURM_CONF"
      exit 0
    fi
    sleep 0.2
  done
  echo "cluster.sh: the node did not become idle; logs in $dir/log" >&2
  sinfo >&2 || true
  tail -n 20 "$dir/log/"*.log >&2 || true
  exit 1
  ;;
down)
  for d in slurmd slurmctld munged; do
    if [ -f "$dir/$d.pid" ]; then
      pid="$(cat "$dir/$d.pid")"
      kill "$pid" 2>/dev/null || true
      for _ in $(seq 1 50); do kill -0 "$pid" 2>/dev/null || break; sleep 0.1; done
    fi
  done
  rm -rf "$dir"
  ;;
*)
  echo "cluster.sh: unknown command $cmd (install | up DIR | down DIR)" >&2
  exit 2
  ;;
esac
