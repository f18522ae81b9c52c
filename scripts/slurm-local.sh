#!/bin/bash
# A one-node Slurm cluster on this machine, then a 4-task `tiny` sweep through it:
# installs Debian's slurm-wlm, munge, slurmdbd and MariaDB (for sacct), starts munged,
# MariaDB, slurmdbd, slurmctld and slurmd on localhost with a minimal slurm.conf whose node
# line is the machine's own (`slurmd -C`), submits the sweep with sbatch, waits, shows
# sinfo/squeue/sacct, gathers the table; then stops one task with SIGTERM as a preemption
# would, submits the array again and shows that finished tasks are skipped and the stopped one
# resumes from its checkpoint.
#
# Needs root and apt-get; runs without systemd (the daemons are started directly).
# Usage: scripts/slurm-local.sh [WORKDIR]     (default /tmp/colorvision-slurm; emptied first)
# The binary is $COLORVISION, else built with `cargo build --release` (honours CARGO_TARGET_DIR).
set -euo pipefail

ROOT=$(cd "$(dirname "$0")/.." && pwd)
WORK=${1:-/tmp/colorvision-slurm}
CLUSTER=colorvision
HOST=$(hostname -s)
say() { printf '\n==> %s\n' "$*"; }

if [ "$(id -u)" != 0 ]; then
    echo "slurm-local.sh: needs root (apt-get, daemons)" >&2
    exit 2
fi

say "installing slurm-wlm, munge, slurmdbd, mariadb-server (if missing)"
if ! command -v slurmctld >/dev/null || ! command -v slurmdbd >/dev/null \
    || ! command -v mariadbd >/dev/null; then
    apt-get update -qq
    DEBIAN_FRONTEND=noninteractive apt-get install -y -qq slurm-wlm munge slurmdbd mariadb-server
fi
dpkg-query -W slurm-wlm munge slurmdbd mariadb-server

if [ -z "${COLORVISION:-}" ]; then
    say "building colorvision"
    (cd "$ROOT" && cargo build --release -q)
    COLORVISION=${CARGO_TARGET_DIR:-$ROOT/target}/release/colorvision
fi
export COLORVISION

say "munged"
[ -s /etc/munge/munge.key ] || mungekey --create --keyfile=/etc/munge/munge.key
chown munge:munge /etc/munge/munge.key && chmod 400 /etc/munge/munge.key
mkdir -p /run/munge && chown munge:munge /run/munge
if ! munge -n 2>/dev/null | unmunge >/dev/null 2>&1; then
    runuser -u munge -- /usr/sbin/munged
    sleep 1
fi
munge -n | unmunge | grep STATUS

say "MariaDB and slurmdbd (the accounting store sacct reads)"
mkdir -p /run/mysqld && chown mysql:mysql /run/mysqld
if ! mysqladmin ping >/dev/null 2>&1; then
    (mysqld_safe >/dev/null 2>&1 &)
    for _ in $(seq 60); do mysqladmin ping >/dev/null 2>&1 && break; sleep 1; done
fi
mysql -e "CREATE DATABASE IF NOT EXISTS slurm_acct_db;
          CREATE USER IF NOT EXISTS 'slurm'@'localhost' IDENTIFIED BY 'colorvision-local';
          GRANT ALL ON slurm_acct_db.* TO 'slurm'@'localhost';"
mkdir -p /var/log/slurm /var/spool/slurmctld /var/spool/slurmd
cat >/etc/slurm/slurmdbd.conf <<EOF
AuthType=auth/munge
DbdHost=localhost
SlurmUser=root
StorageType=accounting_storage/mysql
StorageHost=localhost
StorageUser=slurm
StoragePass=colorvision-local
StorageLoc=slurm_acct_db
LogFile=/var/log/slurm/slurmdbd.log
PidFile=/run/slurmdbd.pid
EOF
chmod 600 /etc/slurm/slurmdbd.conf

# The node as slurmd sees it: real CPUs, sockets, cores, threads and memory (MB).
NODE=$(slurmd -C | head -n 1)
cat >/etc/slurm/slurm.conf <<EOF
ClusterName=$CLUSTER
SlurmctldHost=$HOST
SlurmUser=root
AuthType=auth/munge
StateSaveLocation=/var/spool/slurmctld
SlurmdSpoolDir=/var/spool/slurmd
SlurmctldPidFile=/run/slurmctld.pid
SlurmdPidFile=/run/slurmd.pid
SlurmctldLogFile=/var/log/slurm/slurmctld.log
SlurmdLogFile=/var/log/slurm/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
MpiDefault=none
SelectType=select/cons_tres
SelectTypeParameters=CR_Core_Memory
AccountingStorageType=accounting_storage/slurmdbd
AccountingStorageHost=localhost
JobAcctGatherType=jobacct_gather/linux
JobAcctGatherFrequency=5
ReturnToService=2
$NODE NodeAddr=127.0.0.1 State=UNKNOWN
PartitionName=local Nodes=$HOST Default=YES MaxTime=INFINITE State=UP
EOF
echo "node: $NODE"
pgrep -x slurmdbd >/dev/null || slurmdbd
for _ in $(seq 30); do sacctmgr -n show cluster >/dev/null 2>&1 && break; sleep 1; done
sacctmgr -i add cluster "$CLUSTER" >/dev/null 2>&1 || true

say "slurmctld and slurmd"
pgrep -x slurmctld >/dev/null || slurmctld
pgrep -x slurmd >/dev/null || slurmd
for _ in $(seq 60); do
    sinfo -h -o %T 2>/dev/null | grep -qE '^(idle|mixed|allocated)' && break
    sleep 1
done
scontrol update NodeName="$HOST" State=RESUME >/dev/null 2>&1 || true
sinfo

say "a 4-task tiny sweep"
rm -rf "$WORK" && mkdir -p "$WORK"
cat >"$WORK/sweep.toml" <<EOF
[base]
preset = "tiny"
steps = 1500
[grid]
cones = ["LMS", "LM"]
seed = [0, 1]
[slurm]
concurrency = 2
EOF
"$COLORVISION" sweep "$WORK/sweep.toml" --out "$WORK/sweep"
grep '^#SBATCH' "$WORK/sweep/sweep.sbatch"

# Waits for job $1 to leave the queue, showing squeue every 5 s.
wait_job() {
    while squeue -h -j "$1" 2>/dev/null | grep -q .; do
        squeue -j "$1"
        sleep 5
    done
}

say "sbatch"
JOB=$(sbatch --parsable "$WORK/sweep/sweep.sbatch")
echo "submitted array job $JOB"
sleep 2
say "squeue (every 5 s until the array is done)"
wait_job "$JOB"
sleep 3
say "sacct"
sacct -j "$JOB" --format=JobID%14,JobName%18,State,ExitCode,Elapsed,AllocCPUS,ReqMem,MaxRSS
say "colorvision gather"
"$COLORVISION" gather "$WORK/sweep"
if [ "$(grep -c '| done |' "$WORK/sweep/gather.md")" != 4 ]; then
    echo "slurm-local.sh: not every task finished; see $WORK/sweep/logs" >&2
    exit 1
fi

say "requeue safety: task 0 stopped by SIGTERM mid-run (as a preemption), the array submitted again"
sed -e 's/^steps = 1500/steps = 4000/' -e 's/^cones = .*//' "$WORK/sweep.toml" >"$WORK/again.toml"
"$COLORVISION" sweep "$WORK/again.toml" --out "$WORK/again" >/dev/null
RUN0="$WORK/again/$(ls "$WORK/again" | grep '^000_')"
JOB=$(sbatch --parsable "$WORK/again/sweep.sbatch")
for _ in $(seq 120); do [ -e "$RUN0/.lock" ] && break; sleep 1; done
sleep 8
scancel --signal=TERM --batch "${JOB}_0"
wait_job "$JOB"
JOB2=$(sbatch --parsable "$WORK/again/sweep.sbatch")
echo "submitted again: array job $JOB2"
wait_job "$JOB2"
sleep 3
sacct -j "$JOB,$JOB2" --format=JobID%14,JobName%18,State,ExitCode,Elapsed
grep -hE 'stopped by|resum|finished' "$WORK"/again/logs/task-*.log
"$COLORVISION" gather "$WORK/again"
if [ "$(grep -c '| done |' "$WORK/again/gather.md")" != 2 ]; then
    echo "slurm-local.sh: the resubmitted array did not finish; see $WORK/again/logs" >&2
    exit 1
fi
