#!/usr/bin/env bash
# make test-cluster: the small profile's measurement pipeline through a real SLURM scheduler.
#
# 1. The local run of the small profile (config/test.yaml, results/ci): brought up to date here
#    (nothing to do after `make test-pipeline`).
# 2. A one-node SLURM cluster on loopback (Debian's packages; tests/cluster/slurm_cluster.sh).
# 3. The same settings through `--workflow-profile workflow/profiles/slurm`, into results/cluster,
#    on the local run's recording: ingest → projection → correction → identification, every job
#    an sbatch job. Every result file must equal the local run's byte for byte (the reports'
#    wall times masked: tests/cluster/compare.py).
# 4. A throw-away config with a broken pantographs file: the cluster run must fail, naming the
#    rule (register, the first job to read it) and the path of the job's log, and that log must hold the reason.
# The daemons started in 2 are stopped by PID in an EXIT trap, also when a step fails.
set -euo pipefail
cd "$(dirname "$0")/../.."
BIN=.venv/bin
SPAN_TYPES=(N2 N3)
LOCAL=results/ci
CLUSTER=results/cluster
FAILING=results/cluster_fail

if [ "$(id -u)" -ne 0 ]; then
    echo "test-cluster: needs root (it installs Slurm from Debian's packages and starts its daemons)" >&2
    exit 1
fi

t0=$(date +%s)
step() { echo "test-cluster [$(( $(date +%s) - t0 )) s]: $*"; }

work=$(mktemp -d /tmp/catenary-slurm.XXXXXX)
chmod 755 "$work"                 # the daemons run as users munge and slurm
mkdir -p "$work/trial"
# shellcheck source=tests/cluster/slurm_cluster.sh
source tests/cluster/slurm_cluster.sh
finish() {
    local status=$?
    stop_cluster || status=1
    if pgrep -x munged >/dev/null || pgrep -x slurmctld >/dev/null || pgrep -x slurmd >/dev/null; then
        echo "test-cluster: note: munged/slurmctld/slurmd processes remain that this run did not start:" >&2
        pgrep -a -x 'munged|slurmctld|slurmd' >&2 || true
    fi
    rm -rf "$work"
    step "done (exit $status)"
    exit $status
}
trap finish EXIT

targets() {   # results folder → the identification of every span type
    for t in "${SPAN_TYPES[@]}"; do echo "$1/$t/identification/s_opt.csv"; done
}

step "local run of the small profile (reference)"
$BIN/snakemake --workflow-profile workflow/profiles/default --cores 2 --quiet rules \
    --configfile config/test.yaml -- $(targets $LOCAL)

step "Slurm and munge from Debian's packages"
install_slurm
slurmctld -V

step "the EXIT trap on a failure: a subshell starts a cluster and fails"
(
    trap 'stop_cluster >/dev/null 2>&1' EXIT
    start_cluster "$work/trial" 2>/dev/null
    echo "${CLUSTER_PIDS[*]}" >"$work/trial.pids"
    exit 3
) || true
if [ ! -s "$work/trial.pids" ]; then
    echo "test-cluster: the trial cluster did not start (run the next step's start by hand to see why)" >&2
    exit 1
fi
for pid in $(cat "$work/trial.pids"); do
    if kill -0 "$pid" 2>/dev/null; then
        echo "test-cluster: daemon PID $pid outlived the failed subshell" >&2
        exit 1
    fi
done
echo "test-cluster: the trial's daemons (PIDs $(cat "$work/trial.pids")) are gone"

step "starting a one-node SLURM cluster in $work"
start_cluster "$work"

# What only this test cluster needs: no accounting database, so job states come from squeue
# (the plugin's default, sacct, would wait forever), and quick status polls for a short run.
SLURM_TEST_ARGS=(--slurm-no-account --slurm-status-command squeue --slurm-init-seconds-before-status-checks 2
                 --seconds-between-status-checks 2 --slurm-logdir "$PWD/results/slurm_logs")

cat >"$work/cluster.yaml" <<EOF
results: $CLUSTER
EOF
rm -rf "$CLUSTER" "$FAILING"
step "cluster run: the same settings into $CLUSTER"
timeout -k 30 600 $BIN/snakemake --workflow-profile workflow/profiles/slurm "${SLURM_TEST_ARGS[@]}" \
    --configfile config/test.yaml "$work/cluster.yaml" -- $(targets $CLUSTER)

step "comparing every result file of the cluster run with the local run's"
required=(ingest/recording.parquet spans_report.csv correction/convergence.csv)
for t in "${SPAN_TYPES[@]}"; do
    required+=("$t/spans.parquet" "$t/corrected.parquet" "$t/identification/s_opt.csv")
done
$BIN/python tests/cluster/compare.py "$LOCAL" "$CLUSTER" "${required[@]}"

step "a failing cluster job: a pantographs file with a negative mass"
sed 's/masses_kg: \[7.5, 9.0, 6.0\]/masses_kg: [7.5, -9.0, 6.0]/' config/pantographs.yaml >"$work/bad_pantographs.yaml"
cmp -s config/pantographs.yaml "$work/bad_pantographs.yaml" && { echo "test-cluster: the broken pantographs file is not broken" >&2; exit 1; }
cat >"$work/failing.yaml" <<EOF
results: $FAILING
pantographs: $work/bad_pantographs.yaml
EOF
if timeout -k 30 300 $BIN/snakemake --workflow-profile workflow/profiles/slurm "${SLURM_TEST_ARGS[@]}" \
        --configfile config/test.yaml "$work/failing.yaml" -- $(targets $FAILING) >"$work/failing.out" 2>&1; then
    echo "test-cluster: the run with a broken pantographs file succeeded" >&2
    exit 1
fi
$BIN/python tests/cluster/check_failure.py "$work/failing.out" "$FAILING"
rm -rf "$FAILING"
step "passed"
