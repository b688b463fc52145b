#!/bin/bash
# A throwaway single-node Slurm cluster on this machine (controller and compute node
# here, talking over 127.0.0.1), for tests of deploy/slurm-sweep.sh: its own munge key
# and socket, its own slurm.conf, state and logs, all in one folder. Needs Debian's
# `slurm-wlm` and `munge` (apt-get install slurm-wlm munge) and root (slurmd runs jobs
# as their submitter).
#
#   deploy/slurm-local-cluster.sh start DIR   # prints `export SLURM_CONF=DIR/slurm.conf`
#   SLURM_CONF=DIR/slurm.conf sbatch ...       # use it
#   deploy/slurm-local-cluster.sh stop DIR     # ends the daemons it started
#
# Ports: SLURM_LOCAL_PORT (default: a free port picked at start) for slurmctld and the
# next one for slurmd. The daemons listen on all interfaces (Slurm has no option to bind
# them to the loopback address); they are contacted on 127.0.0.1 only.
set -euo pipefail
cmd=${1:?usage: slurm-local-cluster.sh start|stop DIR}
DIR=${2:?usage: slurm-local-cluster.sh start|stop DIR}

stop() {
    for f in slurmd slurmctld munged; do
        if [ -f "$DIR/$f.pid" ]; then
            pid=$(cat "$DIR/$f.pid")
            kill "$pid" 2>/dev/null || true
            for _ in $(seq 1 50); do kill -0 "$pid" 2>/dev/null || break; sleep 0.1; done
            rm -f "$DIR/$f.pid"
        fi
    done
}

if [ "$cmd" = stop ]; then
    stop
    exit 0
fi
[ "$cmd" = start ] || { echo "unknown command $cmd (start or stop)" >&2; exit 2; }

for b in munged slurmctld slurmd sbatch sinfo; do
    command -v "$b" >/dev/null 2>&1 || [ -x "/usr/sbin/$b" ] || { echo "missing $b (apt-get install slurm-wlm munge)" >&2; exit 3; }
done
export PATH="$PATH:/usr/sbin"
mkdir -p "$DIR"
DIR=$(cd "$DIR" && pwd)
chmod 700 "$DIR"
mkdir -p "$DIR/state" "$DIR/spool" "$DIR/log"

# munge: own key, socket and pid file (the system's munged, if any, is left alone).
if [ ! -f "$DIR/munge.key" ]; then
    dd if=/dev/urandom of="$DIR/munge.key" bs=1024 count=1 status=none
    chmod 600 "$DIR/munge.key"
fi
munged --force --key-file="$DIR/munge.key" --socket="$DIR/munge.socket" \
    --pid-file="$DIR/munged.pid" --log-file="$DIR/log/munged.log" --seed-file="$DIR/munge.seed"

# A free port pair for slurmctld and slurmd (ask the kernel for one).
PORT=${SLURM_LOCAL_PORT:-$(python3 -c 'import socket; s=socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])')}
HOST=$(hostname -s)
CPUS=$(nproc)
MEM_MB=$(awk '/MemTotal/ {print int($2/1024/2)}' /proc/meminfo)
cat >"$DIR/slurm.conf" <<EOF
ClusterName=bearingsweep
SlurmctldHost=$HOST(127.0.0.1)
SlurmctldPort=$PORT
SlurmdPort=$((PORT + 1))
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
CredType=cred/munge
AuthInfo=socket=$DIR/munge.socket
StateSaveLocation=$DIR/state
SlurmdSpoolDir=$DIR/spool
SlurmctldPidFile=$DIR/slurmctld.pid
SlurmdPidFile=$DIR/slurmd.pid
SlurmctldLogFile=$DIR/log/slurmctld.log
SlurmdLogFile=$DIR/log/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SchedulerType=sched/builtin
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
MpiDefault=none
ReturnToService=2
SlurmdTimeout=60
InactiveLimit=0
KillWait=5
NodeName=$HOST NodeAddr=127.0.0.1 CPUs=$CPUS RealMemory=$MEM_MB State=UNKNOWN
PartitionName=local Nodes=ALL Default=YES MaxTime=INFINITE State=UP OverSubscribe=YES
EOF
export SLURM_CONF="$DIR/slurm.conf"
slurmctld -f "$SLURM_CONF" -i
slurmd -f "$SLURM_CONF" -N "$HOST"
# Wait until the node is idle (up to 60 s).
for _ in $(seq 1 120); do
    state=$(sinfo -h -N -o '%T' 2>/dev/null | head -1 || true)
    case "$state" in
        idle*|mixed*|allocated*) echo "export SLURM_CONF=$SLURM_CONF"; exit 0 ;;
    esac
    sleep 0.5
done
echo "the local Slurm node did not come up (state: ${state:-none}); logs in $DIR/log" >&2
tail -n 20 "$DIR/log/"*.log >&2 || true
stop
exit 1
