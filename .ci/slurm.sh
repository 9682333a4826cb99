#!/usr/bin/env bash
# A single-node Slurm cluster for the farm test: `start DIR` writes a minimal
# slurm.conf under DIR, starts munged, slurmctld and slurmd, and waits until
# the node answers; `stop DIR` stops exactly those daemons (by their pid files).
# Needs root and Debian's slurm-wlm and munge packages.
set -euo pipefail
cmd=${1:?usage: slurm.sh start|stop DIR}
dir=$(mkdir -p "${2:?usage: slurm.sh start|stop DIR}" && cd "$2" && pwd)
host=$(hostname -s)

stop_pid() {
  local file=$1
  [ -f "$file" ] || return 0
  local pid
  pid=$(cat "$file")
  if [ -n "$pid" ] && kill -0 "$pid" 2>/dev/null; then
    kill "$pid" 2>/dev/null || true
    for _ in $(seq 50); do kill -0 "$pid" 2>/dev/null || break; sleep 0.1; done
  fi
  rm -f "$file"
}

case $cmd in
start)
  mkdir -p "$dir"/{state,spool,log,munge} /etc/slurm /run/munge
  # munge: a key of our own, sockets and pid under DIR.
  if [ ! -f /etc/munge/munge.key ]; then
    mkdir -p /etc/munge
    dd if=/dev/urandom bs=1 count=1024 of=/etc/munge/munge.key 2>/dev/null
  fi
  chown -R root:root /etc/munge /run/munge 2>/dev/null || true
  chmod 700 /etc/munge && chmod 400 /etc/munge/munge.key
  munged --force --pid-file="$dir/munge/munged.pid" \
    --log-file="$dir/log/munged.log" --seed-file="$dir/munge/seed"
  cpus=$(nproc)
  cat >"$dir/slurm.conf" <<CONF
ClusterName=arbor-ci
SlurmctldHost=$host
AuthType=auth/munge
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
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
ReturnToService=2
MpiDefault=none
SchedulerType=sched/backfill
JobCompType=jobcomp/none
AccountingStorageType=accounting_storage/none
MinJobAge=300
NodeName=$host CPUs=$cpus State=UNKNOWN
PartitionName=debug Nodes=$host Default=YES MaxTime=INFINITE State=UP
CONF
  # The client commands read /etc/slurm/slurm.conf unless SLURM_CONF says otherwise.
  if [ -e /etc/slurm/slurm.conf ] && ! grep -q '^ClusterName=arbor-ci' /etc/slurm/slurm.conf; then
    echo "slurm.sh: /etc/slurm/slurm.conf exists and is not ours; export SLURM_CONF=$dir/slurm.conf" >&2
  else
    cp "$dir/slurm.conf" /etc/slurm/slurm.conf
  fi
  export SLURM_CONF=$dir/slurm.conf
  slurmctld -f "$dir/slurm.conf"
  slurmd -f "$dir/slurm.conf"
  for _ in $(seq 100); do
    if sinfo -h -o '%T' 2>/dev/null | grep -q idle; then
      echo "slurm.sh: single-node cluster up ($host, $cpus CPUs)"; exit 0
    fi
    sleep 0.2
  done
  echo "slurm.sh: the cluster did not come up; logs in $dir/log" >&2
  sinfo >&2 || true
  tail -n 20 "$dir"/log/*.log >&2 || true
  exit 1
  ;;
stop)
  stop_pid "$dir/slurmd.pid"
  stop_pid "$dir/slurmctld.pid"
  stop_pid "$dir/munge/munged.pid"
  ;;
*)
  echo "usage: slurm.sh start|stop DIR" >&2; exit 2 ;;
esac
