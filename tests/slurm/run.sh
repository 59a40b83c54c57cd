#!/usr/bin/env bash
# A sharded bake on a real scheduler: starts a single-node Slurm cluster on this machine
# (munged, slurmctld and slurmd from Debian's munge and slurm-wlm, localhost only, every file
# in a temporary directory), submits the bunny's tiling job, shard array and merge job through
# deploy/slurm/submit.sh, waits for them, and compares the merged file with a single bake byte
# for byte. Every daemon it started is stopped on the way out, pass or fail.
#
# Needs root (slurmd runs jobs as their submitter and slurmctld runs as SlurmUser=root here),
# and the munge and slurm-wlm packages (.ci/run installs them). Builds the binary with cargo
# (CARGO_TARGET_DIR is honoured) unless PATCHVIS names one.
set -euo pipefail

root=$(cd "$(dirname "$0")/../.." && pwd)
shards=4
flags=(--patches 300 --level 3 --resolution 256)
deadline=$((SECONDS + 120))

for tool in munged slurmctld slurmd sbatch squeue sinfo scontrol scancel; do
    command -v "$tool" >/dev/null || {
        echo "error: $tool not found; install munge and slurm-wlm (apt-get install munge slurm-wlm)" >&2
        exit 1
    }
done
if [ "$(id -u)" != 0 ]; then
    echo "error: the Slurm test starts slurmd, which must run as root" >&2
    exit 1
fi
if [ -z "${PATCHVIS:-}" ]; then
    (cd "$root" && cargo build --quiet --bin patchvis)
    PATCHVIS="${CARGO_TARGET_DIR:-$root/target}/debug/patchvis"
fi
PATCHVIS=$(realpath "$PATCHVIS")
export PATCHVIS

tmp=$(mktemp -d /tmp/patchvis-slurm.XXXXXX)
chmod 755 "$tmp"
export SLURM_CONF="$tmp/slurm.conf"

stop() {
    local status=$?
    set +e
    # Jobs first (their steps belong to slurmd), then the daemons, each by its pid file.
    scancel --quiet --user=root 2>/dev/null
    for pidfile in "$tmp/slurmd.pid" "$tmp/slurmctld.pid" "$tmp/munged.pid"; do
        [ -s "$pidfile" ] || continue
        pid=$(cat "$pidfile")
        kill "$pid" 2>/dev/null
        for _ in $(seq 50); do
            kill -0 "$pid" 2>/dev/null || break
            sleep 0.1
        done
        kill -9 "$pid" 2>/dev/null
    done
    if [ "$status" != 0 ]; then
        echo "--- the Slurm test failed; its logs:" >&2
        for log in "$tmp"/*.log "$tmp"/work/logs/*.out; do
            [ -f "$log" ] && { echo "--- $log" >&2; tail -n 20 "$log" >&2; }
        done
    fi
    rm -rf "$tmp"
    exit "$status"
}
trap stop EXIT
trap 'exit 130' INT TERM

free_port() {
    python3 -c 'import socket; s = socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])'
}

# munge: its own key, socket and files (munged refuses group- or world-writable paths).
mkdir -m 755 "$tmp/munge"
dd if=/dev/urandom of="$tmp/munge/munge.key" bs=1 count=1024 status=none
chmod 400 "$tmp/munge/munge.key"
munged --force --key-file="$tmp/munge/munge.key" --socket="$tmp/munge/munge.socket" \
    --pid-file="$tmp/munged.pid" --log-file="$tmp/munged.log" --seed-file="$tmp/munge/seed"

mkdir -p "$tmp/state" "$tmp/spool"
cat >"$SLURM_CONF" <<EOF
ClusterName=patchvis-test
SlurmctldHost=localhost(127.0.0.1)
SlurmctldPort=$(free_port)
SlurmdPort=$(free_port)
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
CredType=cred/munge
AuthInfo=socket=$tmp/munge/munge.socket
StateSaveLocation=$tmp/state
SlurmdSpoolDir=$tmp/spool
SlurmctldPidFile=$tmp/slurmctld.pid
SlurmdPidFile=$tmp/slurmd.pid
SlurmctldLogFile=$tmp/slurmctld.log
SlurmdLogFile=$tmp/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
SchedulerType=sched/backfill
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
MpiDefault=none
SwitchType=switch/none
ReturnToService=2
MailProg=/bin/true
MinJobAge=600
NodeName=localhost NodeAddr=127.0.0.1 CPUs=$(nproc) State=UNKNOWN
PartitionName=test Nodes=localhost Default=YES MaxTime=INFINITE State=UP
EOF

slurmctld -i
slurmd -N localhost
until sinfo -h -o '%T' 2>/dev/null | grep -qE '^(idle|mixed|allocated)'; do
    [ $SECONDS -lt $deadline ] || { echo "error: the Slurm node did not come up" >&2; exit 1; }
    sleep 0.5
done

mkdir "$tmp/work"
mapfile -t jobs < <(PATCHVIS_WORK="$tmp/work/shards" \
    "$root/deploy/slurm/submit.sh" "$root/assets/bunny.ply" "$tmp/work/merged.pvis" \
    "$shards" "${flags[@]}")
echo "submitted: tiling job ${jobs[0]}, shard array ${jobs[1]} (x$shards), merge job ${jobs[2]}"

state() {
    scontrol show job "$1" 2>/dev/null | grep -o 'JobState=[A-Z_]*' | sort -u | cut -d= -f2 | paste -sd,
}
while [ -n "$(squeue -h -o %i 2>/dev/null)" ]; do
    [ $SECONDS -lt $deadline ] || { echo "error: the jobs did not finish within 120 s" >&2; exit 1; }
    sleep 1
done
for job in "${jobs[@]}"; do
    if [ "$(state "$job")" != COMPLETED ]; then
        echo "error: job $job ended $(state "$job"), expected COMPLETED" >&2
        exit 1
    fi
done

"$PATCHVIS" bake "$root/assets/bunny.ply" -o "$tmp/work/single.pvis" "${flags[@]}" -q
if ! cmp "$tmp/work/single.pvis" "$tmp/work/merged.pvis"; then
    echo "error: the merged file differs from the single bake" >&2
    exit 1
fi
echo "slurm: $shards shards merged by job ${jobs[2]} equal the single bake ($(stat -c %s "$tmp/work/merged.pvis") bytes)"
