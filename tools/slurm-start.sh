#!/usr/bin/env bash
# Starts a single-node Slurm cluster on this machine (Debian's slurm-wlm and
# munge, no systemd), for tests of griddy's campaigns on a real scheduler.
# Exit status: 0 when Slurm answers (started here, or already running), 1
# when it cannot start (the reason on stderr). Daemons started here are
# listed in $GRIDDY_SLURM_STATE (default /run/griddy-slurm) for
# tools/slurm-stop.sh, which stops those and only those.
set -u
state=${GRIDDY_SLURM_STATE:-/run/griddy-slurm}
say() { echo "slurm-start: $*" >&2; }

node_ready() {
  # a node that can take jobs: idle, mixed or allocated
  sinfo -h -o '%T' 2>/dev/null | grep -Eq '^(idle|mixed|allocated|completing)'
}

# a job runs to its end within a minute
job_runs() {
  timeout 60 sbatch --wait --quiet --job-name=griddy-probe --output=/dev/null \
    --wrap true >/dev/null 2>&1
}

if command -v sinfo >/dev/null 2>&1 && node_ready; then
  if job_runs; then
    say "Slurm is already running"
    exit 0
  fi
  say "Slurm is running but a test job did not run within a minute"
  exit 1
fi
for cmd in munged munge slurmctld slurmd sinfo sbatch; do
  if ! command -v "$cmd" >/dev/null 2>&1 && [ ! -x "/usr/sbin/$cmd" ]; then
    say "$cmd is not installed (apt-get install slurm-wlm munge)"
    exit 1
  fi
done
if [ "$(id -u)" != 0 ]; then
  say "Slurm is not running and starting it needs root"
  exit 1
fi
export PATH="$PATH:/usr/sbin"
mkdir -p "$state"

# munge: a key, its directories owned by munge, the daemon as munge
if ! munge -n 2>/dev/null | unmunge >/dev/null 2>&1; then
  mkdir -p /etc/munge /var/lib/munge /var/log/munge /run/munge
  if [ ! -s /etc/munge/munge.key ]; then
    dd if=/dev/urandom of=/etc/munge/munge.key bs=1024 count=1 status=none
  fi
  chown -R munge:munge /etc/munge /var/lib/munge /var/log/munge /run/munge
  chmod 400 /etc/munge/munge.key
  chmod 700 /etc/munge /var/lib/munge /var/log/munge
  chmod 755 /run/munge
  runuser -u munge -- munged --pid-file=/run/munge/munged.pid || { say "munged did not start"; exit 1; }
  echo /run/munge/munged.pid >> "$state/pidfiles"
  for _ in $(seq 50); do munge -n 2>/dev/null | unmunge >/dev/null 2>&1 && break; sleep 0.1; done
  if ! munge -n | unmunge >/dev/null 2>&1; then say "munge does not authenticate"; exit 1; fi
fi

# slurm.conf: this host as controller and its one node (as slurmd -C sees it)
host=$(hostname -s)
conf=/etc/slurm/slurm.conf
if [ ! -s "$conf" ] || grep -q "written by griddy" "$conf"; then
  node=$(slurmd -C 2>/dev/null | grep '^NodeName=' | sed 's/ UpTime=.*//')
  [ -n "$node" ] || node="NodeName=$host CPUs=$(nproc)"
  mkdir -p /etc/slurm /var/spool/slurmctld /var/spool/slurmd /var/log/slurm
  cat > "$conf" <<CONF
# written by griddy's tools/slurm-start.sh: a single-node cluster for tests
ClusterName=griddy
SlurmctldHost=$host
AuthType=auth/munge
MpiDefault=none
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
SchedulerType=sched/backfill
SlurmUser=root
ReturnToService=2
JobAcctGatherType=jobacct_gather/none
SlurmctldPidFile=/run/slurmctld.pid
SlurmdPidFile=/run/slurmd.pid
StateSaveLocation=/var/spool/slurmctld
SlurmdSpoolDir=/var/spool/slurmd
SlurmctldLogFile=/var/log/slurm/slurmctld.log
SlurmdLogFile=/var/log/slurm/slurmd.log
$node State=UNKNOWN
PartitionName=debug Nodes=$host Default=YES MaxTime=INFINITE State=UP
CONF
fi

if ! scontrol ping 2>/dev/null | grep -q UP; then
  slurmctld || { say "slurmctld did not start (see /var/log/slurm/slurmctld.log)"; exit 1; }
  echo /run/slurmctld.pid >> "$state/pidfiles"
  for _ in $(seq 100); do scontrol ping 2>/dev/null | grep -q UP && break; sleep 0.1; done
fi
if [ ! -s /run/slurmd.pid ] || ! kill -0 "$(cat /run/slurmd.pid)" 2>/dev/null; then
  slurmd || { say "slurmd did not start (see /var/log/slurm/slurmd.log)"; exit 1; }
  echo /run/slurmd.pid >> "$state/pidfiles"
fi
for _ in $(seq 150); do node_ready && break; sleep 0.2; done
if ! node_ready; then
  scontrol update NodeName="$host" State=RESUME >/dev/null 2>&1
  sleep 1
fi
if node_ready; then
  if job_runs; then
    say "Slurm started: $(sinfo -h -o '%P %D %T' | head -1)"
    exit 0
  fi
  say "Slurm started but a test job did not run within a minute (see /var/log/slurm/)"
  exit 1
fi
say "Slurm started but its node is not ready: $(sinfo -h -N -o '%N %T %E' 2>&1 | head -1)"
exit 1
