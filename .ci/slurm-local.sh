#!/usr/bin/env bash
# A real one-node Slurm (Debian's slurm-wlm and munge) for multifield's CI: the Slurm
# tests of tests/output/slurm.rs submit studies through it (docs/studies.md, "On a cluster").
# Usage: .ci/slurm-local.sh start|stop|status      (as root; .ci/run calls start and stop)
# Env:   SLURM_LOCAL_DIR          state/spool/log/PID dir (default /tmp/multifield-slurm)
#        SLURM_LOCAL_MIN_JOB_AGE  seconds a finished job stays visible (default 300)
#        SLURM_LOCAL_KEEP_STATE=1 keep jobs/node state across restarts (default: clear)
#        SLURM_LOCAL_CPUS         CPUs to advertise (default nproc; more = oversubscribe)
# slurm.conf: one node at 127.0.0.1, proctrack/linuxproc and task/none (no cgroups in
# containers), no accounting daemon (sacct does not work), SlurmUser=SlurmdUser=root.
set -euo pipefail

DIR="${SLURM_LOCAL_DIR:-/tmp/multifield-slurm}"
MIN_JOB_AGE="${SLURM_LOCAL_MIN_JOB_AGE:-300}"
CONF=/etc/slurm/slurm.conf
MARK="# written by multifield .ci/slurm-local.sh"
MUNGE_SOCKET=/run/munge/munge.socket.2
NODE="$(hostname -s)"
T0=$SECONDS

log() { echo "[slurm +$((SECONDS - T0))s] $*" >&2; }

# True if the PID in file $1 is alive and its command name starts with $2.
pid_alive() {
    local f=$1 name=$2 pid comm
    [[ -s $f ]] || return 1
    pid=$(<"$f")
    [[ $pid =~ ^[0-9]+$ ]] || return 1
    comm=$(cat "/proc/$pid/comm" 2>/dev/null) || return 1
    [[ $comm == "$name"* ]]
}

install_pkgs() {
    if dpkg-query -W -f='${Status}\n' slurm-wlm munge 2>/dev/null |
        grep -c '^install ok installed$' | grep -qx 2; then
        return 0
    fi
    log "installing slurm-wlm and munge"
    # Keep package scripts from starting the services themselves.
    local policy=/usr/sbin/policy-rc.d made_policy=0
    if [[ ! -e $policy ]]; then
        printf '#!/bin/sh\nexit 101\n' >"$policy"
        chmod 755 "$policy"
        made_policy=1
    fi
    local rc=0
    export DEBIAN_FRONTEND=noninteractive
    apt-get install -y -qq --no-install-recommends slurm-wlm munge >/dev/null || {
        apt-get update -qq && apt-get install -y -qq --no-install-recommends slurm-wlm munge >/dev/null
    } || rc=$?
    if ((made_policy)); then rm -f "$policy"; fi
    ((rc == 0)) || { log "apt-get install failed (rc=$rc)"; exit "$rc"; }
    log "installed"
}

start_munge() {
    if pid_alive "$DIR/munge/munged.pid" munged; then
        return 0
    fi
    if [[ -S $MUNGE_SOCKET ]] && munge -n -S "$MUNGE_SOCKET" >/dev/null 2>&1; then
        log "using the munged already running on $MUNGE_SOCKET (not managed by this script)"
        return 0
    fi
    if [[ ! -s /etc/munge/munge.key ]]; then
        log "creating /etc/munge/munge.key"
        mungekey --create --keyfile=/etc/munge/munge.key
    fi
    chown munge:munge /etc/munge /etc/munge/munge.key
    chmod 0700 /etc/munge
    chmod 0400 /etc/munge/munge.key
    install -d -o munge -g munge -m 0755 /run/munge
    install -d -o munge -g munge -m 0700 "$DIR/munge"
    # --force: removes a stale socket left by a killed munged.
    runuser -u munge -- /usr/sbin/munged --force \
        --pid-file="$DIR/munge/munged.pid" --log-file="$DIR/munge/munged.log" \
        </dev/null >"$DIR/log/munged.stderr" 2>&1
    local i
    for ((i = 0; i < 50; i++)); do
        munge -n -S "$MUNGE_SOCKET" >/dev/null 2>&1 && return 0
        sleep 0.2
    done
    log "munged did not come up"
    tail -n 20 "$DIR/munge/munged.log" "$DIR/log/munged.stderr" >&2 || true
    exit 1
}

write_conf() {
    local cpus mem_kb mem_mb tmp over=
    cpus=${SLURM_LOCAL_CPUS:-$(nproc)}
    # More CPUs than detected: trust slurm.conf, or slurmd would drain the node.
    if ((cpus > $(nproc))); then over="SlurmdParameters=config_overrides"; fi
    mem_kb=$(awk '/^MemTotal:/ {print $2}' /proc/meminfo)
    mem_mb=$((mem_kb * 95 / 100 / 1024)) # below MemTotal, or slurmd drains the node
    tmp=$(mktemp)
    cat >"$tmp" <<EOF
$MARK; SLURM_LOCAL_DIR=$DIR
ClusterName=local
SlurmctldHost=$NODE(127.0.0.1)
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
# No cgroups in containers: track processes via /proc, no task binding.
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
# CPUs are the consumable unit, so 1-CPU tasks share the node.
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
SchedulerType=sched/backfill
# No slurmdbd: no accounting; finished jobs kept in memory for MinJobAge s.
AccountingStorageType=accounting_storage/none
JobAcctGatherType=jobacct_gather/none
JobCompType=jobcomp/filetxt
JobCompLoc=$DIR/log/jobcomp.log
MinJobAge=$MIN_JOB_AGE
MpiDefault=none
MailProg=/bin/true
ReturnToService=2
StateSaveLocation=$DIR/state
SlurmdSpoolDir=$DIR/spool
SlurmctldPidFile=$DIR/slurmctld.pid
SlurmdPidFile=$DIR/slurmd.pid
SlurmctldLogFile=$DIR/log/slurmctld.log
SlurmdLogFile=$DIR/log/slurmd.log
$over
NodeName=$NODE NodeAddr=127.0.0.1 CPUs=$cpus RealMemory=$mem_mb State=UNKNOWN
PartitionName=debug Nodes=$NODE Default=YES MaxTime=INFINITE State=UP
EOF
    mkdir -p /etc/slurm
    if [[ -e $CONF ]] && ! grep -qF "$MARK" "$CONF"; then
        log "moving existing $CONF to $CONF.orig"
        mv "$CONF" "$CONF.orig"
    fi
    if ! cmp -s "$tmp" "$CONF" 2>/dev/null; then
        install -m 0644 "$tmp" "$CONF"
        if pid_alive "$DIR/slurmctld.pid" slurmctld || pid_alive "$DIR/slurmd.pid" slurmd; then
            log "slurm.conf changed while daemons run; run stop, then start, to apply it"
        fi
    fi
    rm -f "$tmp"
}

node_state() { sinfo -h -n "$NODE" -o %T 2>/dev/null | head -n1; }

# Wait up to $1 s for the node to be usable; 1 on timeout, 2 if drained.
wait_node() {
    local end=$((SECONDS + $1)) st
    while ((SECONDS < end)); do
        st=$(node_state || true)
        case $st in
        idle | mixed | allocated | completing) return 0 ;;
        drain*) return 2 ;; # a drain never clears by itself
        esac
        sleep 1
    done
    return 1
}

show_logs() {
    log "node state: $(node_state || true)"
    scontrol show node "$NODE" 2>&1 | grep -E 'State=|Reason=' >&2 || true
    local f
    for f in "$DIR"/log/slurmctld.log "$DIR"/log/slurmd.log "$DIR"/log/*.stderr "$DIR"/munge/munged.log; do
        [[ -s $f ]] || continue
        echo "==== $f (tail)" >&2
        tail -n 25 "$f" >&2
    done
}

cmd_start() {
    install_pkgs
    mkdir -p "$DIR"/{state,spool,log}
    start_munge
    write_conf
    local clear=-c # drop saved jobs and node state (e.g. DRAIN) from a previous run
    [[ ${SLURM_LOCAL_KEEP_STATE:-0} == 1 ]] && clear=
    if ! pid_alive "$DIR/slurmctld.pid" slurmctld; then
        log "starting slurmctld"
        # shellcheck disable=SC2086
        /usr/sbin/slurmctld $clear </dev/null >"$DIR/log/slurmctld.stderr" 2>&1 ||
            { show_logs; exit 1; }
    fi
    if ! pid_alive "$DIR/slurmd.pid" slurmd; then
        log "starting slurmd"
        /usr/sbin/slurmd -N "$NODE" </dev/null >"$DIR/log/slurmd.stderr" 2>&1 ||
            { show_logs; exit 1; }
    fi
    if ! wait_node 30; then
        log "node not ready ($(node_state || true)); trying state=resume"
        scontrol update nodename="$NODE" state=resume || true
        wait_node 30 || { show_logs; log "start failed"; exit 1; }
    fi
    log "ready: node $NODE $(node_state), $(sinfo -h -n "$NODE" -o %c) CPUs, dir $DIR"
}

# Stop the process whose PID is in file $1 (command name $2); wait until gone.
stop_pid() {
    local f=$1 name=$2 pid i
    if ! pid_alive "$f" "$name"; then
        rm -f "$f"
        return 0
    fi
    pid=$(<"$f")
    log "stopping $name (pid $pid)"
    kill -TERM "$pid" 2>/dev/null || true
    for ((i = 0; i < 150; i++)); do
        [[ -e /proc/$pid ]] || { rm -f "$f"; return 0; }
        sleep 0.2
    done
    log "$name (pid $pid) still alive after 30 s; sending SIGKILL"
    kill -KILL "$pid" 2>/dev/null || true
    for ((i = 0; i < 50; i++)); do
        [[ -e /proc/$pid ]] || { rm -f "$f"; return 0; }
        sleep 0.2
    done
    log "$name (pid $pid) did not exit"
    return 1
}

cmd_stop() {
    local rc=0 i
    if pid_alive "$DIR/slurmctld.pid" slurmctld && pid_alive "$DIR/slurmd.pid" slurmd; then
        # Cancel remaining jobs so no slurmstepd/job processes outlive slurmd.
        if [[ -n $(squeue -h -o %i 2>/dev/null) ]]; then
            log "cancelling remaining jobs"
            scancel --partition=debug 2>/dev/null || true
            for ((i = 0; i < 60; i++)); do
                [[ -z $(squeue -h -o %i 2>/dev/null) ]] && break
                sleep 1
            done
        fi
    fi
    stop_pid "$DIR/slurmd.pid" slurmd || rc=1
    stop_pid "$DIR/slurmctld.pid" slurmctld || rc=1
    stop_pid "$DIR/munge/munged.pid" munged || rc=1
    log "stopped"
    return "$rc"
}

cmd_status() {
    local n
    for n in slurmctld slurmd; do
        if pid_alive "$DIR/$n.pid" "$n"; then echo "$n: running (pid $(<"$DIR/$n.pid"))"; else echo "$n: not running"; fi
    done
    if pid_alive "$DIR/munge/munged.pid" munged; then echo "munged: running (pid $(<"$DIR/munge/munged.pid"))"; else echo "munged: not running (by PID file)"; fi
    sinfo || true
    squeue || true
}

case "${1:-}" in
start) cmd_start ;;
stop) cmd_stop ;;
status) cmd_status ;;
*)
    echo "usage: $0 start|stop|status" >&2
    exit 2
    ;;
esac
