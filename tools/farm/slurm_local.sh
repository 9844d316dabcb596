#!/bin/sh
# Tries the Slurm scripts on a real scheduler: installs Slurm from Debian's packages
# (slurm-wlm, munge), starts a one-node cluster on this machine (munged,
# slurmctld, slurmd), submits a space-time solve as a job array of N shards and a
# dependent merge (tools/farm/slurm/submit.sh), waits, and compares the merged
# file with the single-machine solve at every frame (tools/farm/compare.py). Then
# it does it again with one array task failing: the merge fails naming that
# shard, the index is re-run alone, and the merge completes.
#
#   sudo tools/farm/slurm_local.sh BIN WORK_DIR N SCENE [solve settings...]
#
# Needs root (apt-get, the daemons). Leaves the daemons running unless STOP=1.
# Writes /etc/slurm/slurm.conf (and keeps an existing one as slurm.conf.orig).
# Recorded run: BENCHMARKS.md, "Farm".
set -eu
BIN=$(realpath "$1"); WORK=$(realpath -m "$2"); N=$3; SCENE=$(realpath "$4"); shift 4
HERE=$(cd "$(dirname "$0")" && pwd)
now() { date +%s.%N; }
say() { echo "[$(date -u +%T)] $*"; }

say "installing slurm-wlm and munge"
if ! command -v slurmctld >/dev/null || ! command -v munged >/dev/null; then
  apt-get update -q
  DEBIAN_FRONTEND=noninteractive apt-get install -y -q --no-install-recommends slurm-wlm munge
fi
slurmctld -V

say "starting munged"
if [ ! -s /etc/munge/munge.key ]; then
  dd if=/dev/urandom of=/etc/munge/munge.key bs=1024 count=1 2>/dev/null
fi
chown munge:munge /etc/munge/munge.key; chmod 400 /etc/munge/munge.key
mkdir -p /run/munge /var/log/munge /var/lib/munge
chown munge:munge /run/munge /var/log/munge /var/lib/munge
pgrep -x munged >/dev/null || runuser -u munge -- /usr/sbin/munged
munge -n | unmunge >/dev/null

say "writing /etc/slurm/slurm.conf for one node"
HOST=$(hostname -s)
CPUS=$(nproc)
MEM=$(awk '/MemTotal/ { print int($2 / 1024 * 0.9) }' /proc/meminfo)
[ -f /etc/slurm/slurm.conf ] && ! grep -q "tools/farm/slurm_local.sh" /etc/slurm/slurm.conf &&
  cp /etc/slurm/slurm.conf /etc/slurm/slurm.conf.orig
mkdir -p /etc/slurm /var/spool/slurmctld /var/spool/slurmd /var/log/slurm
cat > /etc/slurm/slurm.conf <<CONF
# written by rhier tools/farm/slurm_local.sh: a one-node cluster on localhost
ClusterName=rhier
SlurmctldHost=$HOST
SlurmUser=root
AuthType=auth/munge
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
ReturnToService=2
MpiDefault=none
StateSaveLocation=/var/spool/slurmctld
SlurmdSpoolDir=/var/spool/slurmd
SlurmctldPidFile=/run/slurmctld.pid
SlurmdPidFile=/run/slurmd.pid
SlurmctldLogFile=/var/log/slurm/slurmctld.log
SlurmdLogFile=/var/log/slurm/slurmd.log
MinJobAge=3600
NodeName=$HOST CPUs=$CPUS RealMemory=$MEM State=UNKNOWN
PartitionName=main Nodes=ALL Default=YES MaxTime=INFINITE State=UP
CONF

say "starting slurmctld and slurmd"
pgrep -x slurmctld >/dev/null || slurmctld
pgrep -x slurmd >/dev/null || slurmd
i=0
until sinfo -h -o "%T" 2>/dev/null | grep -Eq "idle|mixed|alloc"; do
  i=$((i + 1)); [ "$i" -lt 60 ] || { sinfo; tail /var/log/slurm/*.log; exit 1; }
  scontrol update nodename="$HOST" state=resume 2>/dev/null || true
  sleep 1
done
sinfo

# Waits for job $1 to leave the queue; prints its state and exit code.
wait_job() {
  while squeue -h -j "$1" 2>/dev/null | grep -q .; do sleep 2; done
  scontrol show job "$1" | grep -Eo "JobState=[A-Z_]+|ExitCode=[0-9:]+" | tr '\n' ' '; echo
}

run_farm() { # $1: the run's directory, then the solve settings
  dir=$1; shift
  mkdir -p "$dir"; rm -f "$dir"/part-*.rhier "$dir"/merged.rhier
  t0=$(now)
  ids=$(RHIER=$BIN "$HERE/slurm/submit.sh" "$N" "$dir" "$SCENE" "$@")
  array=${ids% *}; merge=${ids#* }
  say "submitted array $array ($N tasks) and merge $merge"
  wait_job "$merge"
  say "farm wall time $(echo "$(now) - $t0" | bc) s"
  for log in "$dir"/rhier-shard-*.log "$dir"/rhier-merge-*.log; do
    [ -s "$log" ] && { echo "--- $(basename "$log")"; cat "$log"; }
  done
}

say "farm: $N shards of $(basename "$SCENE") $*"
SETTINGS="$*"
run_farm "$WORK/farm" "$@"
[ -f "$WORK/farm/merged.rhier" ] || { say "no merged file"; exit 1; }

say "single machine, for comparison"
t0=$(now)
"$BIN" solve "$SCENE" "$@" -q -o "$WORK/single.rhier"
say "single-machine time $(echo "$(now) - $t0" | bc) s"
FPS=$(echo " $SETTINGS " | sed -n 's/.* --fps \([0-9.]*\) .*/\1/p'); FPS=${FPS:-25}
python3 "$HERE/compare.py" --rhier "$BIN" --scene "$SCENE" --fps "$FPS" --quiet \
  "$WORK/farm/merged.rhier" "$WORK/single.rhier"
"$BIN" inspect --no-verify "$WORK/farm/merged.rhier" | head -4

say "again with array task 1 failing"
export RHIER_FAIL_INDEX=1
run_farm "$WORK/fail" "$@"
unset RHIER_FAIL_INDEX
[ ! -f "$WORK/fail/merged.rhier" ] || { say "a merge with a shard missing wrote a file"; exit 1; }
say "re-running array index 1 alone, then the merge"
t0=$(now)
one=$(cd "$WORK/fail" && RHIER=$BIN sbatch --parsable --array=1 --cpus-per-task=1 \
  "$HERE/slurm/shard.sbatch" "$N" "$WORK/fail" "$SCENE" "$@")
merge=$(cd "$WORK/fail" && RHIER=$BIN sbatch --parsable --dependency=afterok:"$one" \
  "$HERE/slurm/merge.sbatch" "$WORK/fail")
wait_job "$merge"
say "re-run and merge $(echo "$(now) - $t0" | bc) s"
say "the completed set against the first farm run (identical at every frame):"
python3 "$HERE/compare.py" --rhier "$BIN" --scene "$SCENE" --fps "$FPS" --quiet --tol 0 \
  "$WORK/fail/merged.rhier" "$WORK/farm/merged.rhier"

if [ "${STOP:-0}" = 1 ]; then
  scontrol shutdown || true
  [ -f /run/munge/munged.pid ] && kill "$(cat /run/munge/munged.pid)" || true
fi
