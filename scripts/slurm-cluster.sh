#!/usr/bin/env bash
# A throw-away single-node Slurm cluster kept in one directory, for the test
# of `haptex db build` as an `sbatch --array` job
# (crates/haptex-cli/tests/slurm_cli.rs). Debian bookworm's munge,
# slurmctld, slurmd and slurm-client (Slurm 22.05), all run as root.
#
#   scripts/slurm-cluster.sh DIR
#
# Writes DIR/munge.key (a fresh key), DIR/slurm.conf and DIR/cgroup.conf,
# starts munged, slurmctld and slurmd in the foreground as children of this
# script (their logs in DIR), waits until the node takes jobs and prints
#
#   ready SLURM_CONF=DIR/slurm.conf
#
# on stdout. Clients (sbatch, squeue, scontrol) use the cluster with that
# SLURM_CONF. The cluster runs until this script's stdin ends (the test
# closes the pipe, or dies, which closes it too; Ctrl-D at a terminal) or
# it gets SIGINT or SIGTERM (Ctrl-C): then it cancels the jobs still there,
# stops the daemons, waits for them and exits 0.
#
# Exit status 77: the cluster cannot run here (not root, a program missing,
# a daemon that did not start or a node that did not come up); the reason
# is on stderr, with the end of the daemon's log, and nothing is left
# running. Any other failure is a bug of this script.
#
# Ports: SLURM_CLUSTER_PORT (default 6817) for slurmctld, the next one for
# slurmd. DIR must be a short path: munge's socket lives in it (a Unix
# socket's path has at most 107 bytes).
set -uo pipefail

if [ $# -ne 1 ]; then
    echo "usage: $0 DIR" >&2
    exit 2
fi
DIR=$1
declare -A PID=() # daemon name -> pid

log() { echo "slurm-cluster: $*" >&2; }

tail_log() {
    [ -s "$1" ] && { echo "--- last lines of $1:" && tail -n 15 "$1"; } >&2
    return 0
}

running() { [ -n "${PID[$1]:-}" ] && kill -0 "${PID[$1]}" 2>/dev/null; }

# SIGTERM to the named daemons, SIGKILL to those still there after 10 s;
# then reap them.
terminate() {
    local name i left
    for name in "$@"; do
        running "$name" && kill -TERM "${PID[$name]}" 2>/dev/null
    done
    for ((i = 0; i < 100; i++)); do
        left=0
        for name in "$@"; do
            running "$name" && left=1
        done
        [ $left = 0 ] && break
        sleep 0.1
    done
    for name in "$@"; do
        if running "$name"; then
            log "$name (${PID[$name]}) ignored SIGTERM for 10 s: SIGKILL"
            kill -KILL "${PID[$name]}" 2>/dev/null
        fi
        [ -n "${PID[$name]:-}" ] && wait "${PID[$name]}" 2>/dev/null
        unset "PID[$name]"
    done
}

stop() {
    local i
    # Jobs still queued or running (a test that failed or timed out):
    # cancel them while slurmctld and slurmd can, so that no job step
    # (slurmstepd and the job's processes) outlives the cluster.
    if running slurmctld && running slurmd && [ -n "$(squeue -h -o %i 2>/dev/null)" ]; then
        log "cancelling the jobs still there"
        scancel --quiet --partition debug 2>/dev/null
        for ((i = 0; i < 150; i++)); do
            [ -z "$(squeue -h -o %i 2>/dev/null)" ] && break
            sleep 0.1
        done
    fi
    # slurmd and slurmctld together (each takes about 2 s to stop), then
    # munged, which they use until they exit.
    terminate slurmd slurmctld
    terminate munged
}

cannot() { # the cluster cannot run here: say why, leave nothing running
    log "$*"
    stop
    exit 77
}

# Starts daemon NAME (the rest: its foreground command line) with stderr
# in DIR/NAME.err.
daemon() {
    local name=$1
    shift
    "$@" </dev/null >/dev/null 2>"$DIR/$name.err" &
    PID[$name]=$!
    sleep 0.2
    running "$name" || {
        tail_log "$DIR/$name.err"
        tail_log "$DIR/$name.log"
        cannot "$name did not start"
    }
}

[ "$(id -u)" = 0 ] || cannot "needs root (slurmd runs jobs as their user; this script runs every daemon as root)"
for prog in munged munge unmunge slurmctld slurmd sbatch squeue scancel scontrol sinfo; do
    command -v "$prog" >/dev/null 2>&1 \
        || cannot "$prog not found (Debian: apt-get install munge slurmctld slurmd slurm-client)"
done
mkdir -p "$DIR/state" "$DIR/spool" || cannot "cannot create $DIR"
DIR=$(cd "$DIR" && pwd)
[ ${#DIR} -le 80 ] || cannot "$DIR is too long a path for munge's socket"
# munged wants its socket's directory searchable by everyone.
chmod 755 "$DIR"
export SLURM_CONF="$DIR/slurm.conf"
# The cluster's own clients must not read a job's variables of an
# enclosing cluster (sbatch takes its options from SBATCH_* too).
for name in $(compgen -e); do
    case $name in SLURM_CONF) ;; SLURM_* | SBATCH_* | SQUEUE_*) unset "$name" ;; esac
done

trap 'stop; exit 0' INT TERM

# munge: a fresh key readable by root only, and a private socket (Slurm
# finds it through AuthInfo in slurm.conf).
head -c 1024 /dev/urandom >"$DIR/munge.key" && chmod 400 "$DIR/munge.key" || cannot "cannot write the munge key"
daemon munged munged --foreground --key-file="$DIR/munge.key" --socket="$DIR/munge.socket" \
    --pid-file="$DIR/munged.pid" --seed-file="$DIR/munged.seed"
munge -n --socket="$DIR/munge.socket" | unmunge --socket="$DIR/munge.socket" >/dev/null 2>"$DIR/unmunge.err" \
    || { tail_log "$DIR/unmunge.err"; tail_log "$DIR/munged.log"; cannot "munged does not decode its own credential"; }

PORT=${SLURM_CLUSTER_PORT:-6817}
# The node as slurmd finds it (name, CPUs, sockets, cores, threads),
# without RealMemory: slurmctld drains a node that has less memory than
# slurm.conf says, and how much is free is no business of this test.
NODE=$(slurmd -C 2>/dev/null | head -n 1 | sed -E 's/ RealMemory=[0-9]+//')
[[ "$NODE" == NodeName=?* ]] || cannot "slurmd -C did not describe this node"
HOST=${NODE%% *}
HOST=${HOST#NodeName=}

cat >"$DIR/slurm.conf" <<EOF
# A single-node cluster, all of it in $DIR.
ClusterName=haptex-test
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
SlurmctldLogFile=$DIR/slurmctld.log
SlurmdLogFile=$DIR/slurmd.log
# No cgroups (a container's cgroup tree is not Slurm's to manage): jobs are
# tracked by their process tree and not bound to cores.
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
# No slurmdbd, so no sacct: finished jobs stay in slurmctld's memory for
# 10 minutes, where scontrol shows each array task's state and exit code.
AccountingStorageType=accounting_storage/none
MinJobAge=600
SchedulerType=sched/backfill
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
MpiDefault=none
ReturnToService=2
$NODE NodeAddr=127.0.0.1 State=UNKNOWN
PartitionName=debug Nodes=$HOST Default=YES MaxTime=INFINITE State=UP
EOF
# slurmd 22.05 loads a cgroup plugin at start even when nothing uses it
# (CgroupPlugin=disabled came with 23.02); autodetect finds this system's.
echo "CgroupPlugin=autodetect" >"$DIR/cgroup.conf"

# -i: no state of an earlier cluster to recover (there is none).
daemon slurmctld slurmctld -D -i
daemon slurmd slurmd -D -N "$HOST"

# The node takes jobs once slurmctld has registered it as idle.
state=""
for ((i = 0; i < 300; i++)); do
    state=$(sinfo -h -n "$HOST" -o %T 2>/dev/null | head -n 1)
    [ "$state" = idle ] && break
    for name in munged slurmctld slurmd; do
        running "$name" || {
            tail_log "$DIR/$name.err"
            tail_log "$DIR/$name.log"
            cannot "$name exited after starting"
        }
    done
    sleep 0.1
done
if [ "$state" != idle ]; then
    scontrol show node "$HOST" >&2
    tail_log "$DIR/slurmctld.log"
    tail_log "$DIR/slurmd.log"
    cannot "node $HOST is '${state:-unknown}', not idle, 30 s after slurmd started"
fi
log "node $HOST idle (Slurm $(sinfo --version | cut -d' ' -f2))"
echo "ready SLURM_CONF=$SLURM_CONF"

# Until stdin ends. `read` returns on a signal, so the trap runs at once.
while read -r _; do :; done
stop
exit 0
