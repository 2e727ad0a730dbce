#!/usr/bin/env bash
# scripts/slurm-local.sh start DIR | stop DIR: a one-node Slurm cluster on this machine (Debian's
# slurm-wlm and munge), everything in DIR: a munge key and socket of its own, a generated
# slurm.conf (this host as the one node with all its cores, ports nobody else uses), state, spool,
# logs and pid files. After `start`, `export SLURM_CONF=DIR/slurm.conf` points sbatch, squeue and
# sinfo at it. For tests/test_slurm.sh and for trying docs/cluster.md without a cluster. When a
# daemon does not come up, `start` prints its own log and exits 1.
set -uo pipefail
cmd=${1:-} D=${2:-}
if [ -z "$cmd" ] || [ -z "$D" ]; then
    echo "usage: $0 start|stop DIR" >&2
    exit 2
fi

stop() {
    for p in slurmd slurmctld; do
        if [ -f "$D/$p.pid" ]; then
            pid=$(cat "$D/$p.pid")
            kill "$pid" 2>/dev/null
            for _ in $(seq 50); do kill -0 "$pid" 2>/dev/null || break; sleep 0.1; done
            kill -9 "$pid" 2>/dev/null
            rm -f "$D/$p.pid"
        fi
    done
    if [ -f "$D/munge/munged.pid" ]; then
        pid=$(cat "$D/munge/munged.pid")
        kill "$pid" 2>/dev/null
        for _ in $(seq 50); do kill -0 "$pid" 2>/dev/null || break; sleep 0.1; done
        rm -f "$D/munge/munged.pid"
    fi
}

if [ "$cmd" = stop ]; then
    stop
    exit 0
fi
[ "$cmd" = start ] || { echo "$0: start or stop, not '$cmd'" >&2; exit 2; }
for prog in munged slurmctld slurmd sbatch; do
    command -v "$prog" >/dev/null 2>&1 || PATH=$PATH:/usr/sbin
    command -v "$prog" >/dev/null 2>&1 || {
        echo "$0: $prog not found (Debian packages slurm-wlm and munge)" >&2
        exit 1
    }
done
fail() { # message, then the daemons' own logs
    echo "$0: $1" >&2
    for log in "$D/munge/munged.log" "$D/slurmctld.log" "$D/slurmd.log"; do
        [ -s "$log" ] && { echo "--- $log" >&2; tail -20 "$log" >&2; }
    done
    stop
    exit 1
}

mkdir -p "$D/munge" "$D/state" "$D/spool" || exit 1
chmod 711 "$D" "$D/munge"
user=$(id -un)
# munge: a key of our own (1024 random bytes, readable by its owner only) and a socket in DIR
dd if=/dev/urandom of="$D/munge/munge.key" bs=1024 count=1 status=none
chmod 400 "$D/munge/munge.key"
munged --force --key-file="$D/munge/munge.key" --socket="$D/munge/munge.socket" \
    --pid-file="$D/munge/munged.pid" --log-file="$D/munge/munged.log" \
    --seed-file="$D/munge/munged.seed" 2>>"$D/munge/munged.log" || fail "munged did not start"

# two free TCP ports, for slurmctld and slurmd
read -r p1 p2 < <(python3 -c 'import socket
s = [socket.socket() for _ in range(2)]
for x in s: x.bind(("127.0.0.1", 0))
print(*[x.getsockname()[1] for x in s])')
host=$(hostname -s)
cat >"$D/slurm.conf" <<EOF
# written by scripts/slurm-local.sh: one node, this host, for tests
ClusterName=tandem
SlurmctldHost=$host
SlurmctldPort=$p1
SlurmdPort=$p2
AuthType=auth/munge
CredType=cred/munge
AuthInfo=socket=$D/munge/munge.socket
SlurmUser=$user
SlurmdUser=$user
StateSaveLocation=$D/state
SlurmdSpoolDir=$D/spool
SlurmctldPidFile=$D/slurmctld.pid
SlurmdPidFile=$D/slurmd.pid
SlurmctldLogFile=$D/slurmctld.log
SlurmdLogFile=$D/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
AccountingStorageType=accounting_storage/none
JobAcctGatherType=jobacct_gather/none
JobCompType=jobcomp/none
MpiDefault=none
ReturnToService=2
SchedulerType=sched/backfill
NodeName=$host CPUs=$(nproc) State=UNKNOWN
PartitionName=tandem Nodes=$host Default=YES MaxTime=INFINITE State=UP
EOF
export SLURM_CONF=$D/slurm.conf
slurmctld -f "$SLURM_CONF" 2>>"$D/slurmctld.log" || fail "slurmctld did not start"
slurmd -f "$SLURM_CONF" 2>>"$D/slurmd.log" || fail "slurmd did not start"
for _ in $(seq 150); do
    state=$(sinfo -h -o %t 2>/dev/null)
    [ "$state" = idle ] && exit 0
    sleep 0.2
done
fail "the node did not come up idle within 30 s (sinfo says '${state:-nothing}')"
