# A one-node SLURM cluster on loopback, private to one shell (sourced by tests/cluster/run.sh).
#
#   start_cluster DIR   install the Debian packages if missing, write DIR/slurm.conf, start munged,
#                       slurmctld and slurmd in the foreground of this shell, wait for the node to
#                       be idle; exports SLURM_CONF so sbatch/squeue use this cluster only
#   stop_cluster        cancel its jobs, stop exactly the daemons start_cluster started (by PID),
#                       and fail if one of them is still alive
#
# Root only (the packages, and slurmd runs jobs as their user). Own munge key and socket, own
# state and spool directories in DIR. One file outside DIR: /etc/slurm/slurm.conf becomes a link
# to DIR/slurm.conf while the cluster runs (the SLURM plugin's job step drops SLURM_CONF before
# its srun, which then reads the default path); a file found there is put back by stop_cluster.

CLUSTER_PIDS=()
CLUSTER_NAMES=()

_cluster_log() { echo "test-cluster: $*" >&2; }

install_slurm() {
    local missing=()
    for cmd in munged mungekey slurmctld slurmd sbatch squeue scontrol; do
        command -v "$cmd" >/dev/null 2>&1 || missing+=("$cmd")
    done
    if [ ${#missing[@]} -gt 0 ]; then
        _cluster_log "installing munge and Slurm from Debian's packages (missing: ${missing[*]})"
        apt-get update -qq
        DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends \
            munge slurmctld slurmd slurm-client >/dev/null
    fi
}

_start_daemon() {   # name, command...: started in the background of this shell, PID recorded
    local name=$1; shift
    "$@" >"$CLUSTER_DIR/log/$name.out" 2>&1 &
    CLUSTER_PIDS+=("$!")
    CLUSTER_NAMES+=("$name")
    _cluster_log "started $name (PID $!)"
}

start_cluster() {
    local dir=$1
    CLUSTER_DIR=$dir
    install_slurm
    for port in 6817 6818; do
        if (exec 3<>"/dev/tcp/127.0.0.1/$port") 2>/dev/null; then
            _cluster_log "port $port is already in use (another Slurm?): refusing to start a second cluster"
            return 1
        fi
    done
    chmod 755 "$dir"
    mkdir -p "$dir/munge" "$dir/state" "$dir/spool" "$dir/log"
    # munge: own key and socket, run as user munge (munged refuses root)
    mungekey --create --keyfile="$dir/munge/munge.key" --force >/dev/null
    chown -R munge:munge "$dir/munge"
    chmod 755 "$dir/munge"           # the socket is for every local user (slurm among them)
    chmod 600 "$dir/munge/munge.key"
    chown slurm:slurm "$dir/state"
    chmod 777 "$dir/log"              # daemon logs: slurmctld writes as slurm, the others as root/munge
    local cpus mem_mb
    cpus=$(nproc)
    mem_mb=$(awk '/MemTotal/ {printf "%d", 0.8 * $2 / 1024}' /proc/meminfo)
    cat >"$dir/slurm.conf" <<EOF
ClusterName=catenary-test
SlurmctldHost=localhost
SlurmUser=slurm
AuthType=auth/munge
AuthInfo=socket=$dir/munge/munge.socket
CredType=cred/munge
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SelectType=select/cons_tres
SelectTypeParameters=CR_Core_Memory
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
MinJobAge=300
ReturnToService=2
SlurmctldPort=6817
SlurmdPort=6818
StateSaveLocation=$dir/state
SlurmdSpoolDir=$dir/spool
SlurmctldPidFile=$dir/log/slurmctld.pid
SlurmdPidFile=$dir/spool/slurmd.pid
SlurmctldLogFile=$dir/log/slurmctld.log
SlurmdLogFile=$dir/spool/slurmd.log
NodeName=localhost NodeAddr=127.0.0.1 CPUs=$cpus RealMemory=$mem_mb State=UNKNOWN
PartitionName=main Nodes=localhost Default=YES MaxTime=INFINITE State=UP
EOF
    export SLURM_CONF="$dir/slurm.conf"
    mkdir -p /etc/slurm
    if [ -e /etc/slurm/slurm.conf ] || [ -L /etc/slurm/slurm.conf ]; then
        mv /etc/slurm/slurm.conf "$dir/slurm.conf.found"
    fi
    ln -s "$SLURM_CONF" /etc/slurm/slurm.conf
    CLUSTER_CONF_LINK=1
    _start_daemon munged setpriv --reuid=munge --regid=munge --init-groups \
        munged --foreground --socket="$dir/munge/munge.socket" --key-file="$dir/munge/munge.key" \
        --pid-file="$dir/munge/munged.pid" --log-file="$dir/munge/munged.log" --seed-file="$dir/munge/munged.seed"
    for _ in $(seq 50); do [ -S "$dir/munge/munge.socket" ] && break; sleep 0.1; done
    if [ ! -S "$dir/munge/munge.socket" ]; then
        _cluster_log "munged did not start (its log follows)"
        cat "$dir/munge/munged.log" "$CLUSTER_DIR/log/munged.out" >&2 2>/dev/null || true
        return 1
    fi
    _start_daemon slurmctld slurmctld -D -i -f "$SLURM_CONF"
    _start_daemon slurmd slurmd -D -N localhost -f "$SLURM_CONF"
    for _ in $(seq 60); do
        if [ "$(sinfo --noheader --nodes=localhost --format=%t 2>/dev/null)" = "idle" ]; then
            _cluster_log "node localhost idle: $cpus CPUs, ${mem_mb} MB"
            return 0
        fi
        sleep 0.5
    done
    _cluster_log "the node never became idle; slurmctld log:"
    tail -n 20 "$dir/log/slurmctld.log" >&2 || true
    return 1
}

stop_cluster() {
    local status=0 i pid
    if [ -n "${SLURM_CONF:-}" ] && kill -0 "${CLUSTER_PIDS[1]:-0}" 2>/dev/null; then
        # this private cluster's jobs; bounded: a client waits long for a controller it cannot reach
        timeout 5 scancel --full --quiet --user "$(id -un)" 2>/dev/null || true
        for _ in $(seq 10); do
            [ -z "$(timeout 3 squeue --noheader 2>/dev/null)" ] && break
            sleep 0.5
        done
    fi
    for ((i = ${#CLUSTER_PIDS[@]} - 1; i >= 0; i--)); do     # slurmd, slurmctld, then munged
        kill -TERM "${CLUSTER_PIDS[$i]}" 2>/dev/null || true
    done
    for ((i = ${#CLUSTER_PIDS[@]} - 1; i >= 0; i--)); do
        pid=${CLUSTER_PIDS[$i]}
        for _ in $(seq 50); do kill -0 "$pid" 2>/dev/null || break; sleep 0.1; done
        if kill -0 "$pid" 2>/dev/null; then
            _cluster_log "${CLUSTER_NAMES[$i]} (PID $pid) ignored SIGTERM: killing it"
            kill -KILL "$pid" 2>/dev/null || true
            sleep 0.2
        fi
        wait "$pid" 2>/dev/null || true
        if kill -0 "$pid" 2>/dev/null; then
            _cluster_log "${CLUSTER_NAMES[$i]} (PID $pid) is still running"
            status=1
        else
            _cluster_log "stopped ${CLUSTER_NAMES[$i]} (PID $pid)"
        fi
    done
    CLUSTER_PIDS=()
    CLUSTER_NAMES=()
    if [ -n "${CLUSTER_CONF_LINK:-}" ]; then
        rm -f /etc/slurm/slurm.conf
        if [ -e "$CLUSTER_DIR/slurm.conf.found" ] || [ -L "$CLUSTER_DIR/slurm.conf.found" ]; then
            mv "$CLUSTER_DIR/slurm.conf.found" /etc/slurm/slurm.conf
        fi
        CLUSTER_CONF_LINK=
    fi
    return $status
}
