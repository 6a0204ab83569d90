#!/usr/bin/env bash
# Proves scripts/slurm/sweep.sbatch on a real (single-node) Slurm: starts one with
# local-cluster.sh, runs the same sweep once unsharded and once as a 4-task job array,
# merges the shards, and compares: sweep.csv must be byte-identical apart from the timing
# columns (*_ms), and every picture under images/ byte-identical. Prints both wall times.
#
#   scripts/slurm/prove.sh [SCENE] [sweep options]     (as root; default: jacksboro,
#                                                       --levels 1,2,4,8,16,32,64
#                                                       --precision gpu,exact)
#
# Uses ${BUILD_DIR:-build}/tessref (build first: scripts/build.sh). Work goes to
# out/slurm-proof/; the cluster is stopped on exit. Exit 0 when the merged result matches.
set -euo pipefail
cd "$(dirname "$0")/../.."
root=$(pwd)
export TESSREF=${TESSREF:-$root/${BUILD_DIR:-build}/tessref}
[[ -x "$TESSREF" ]] || { echo "prove: no tessref at $TESSREF (build first: scripts/build.sh)" >&2; exit 2; }
scene=${1:-data/scenes/jacksboro.toml}
shift || true
if [[ $# -eq 0 ]]; then set -- --levels 1,2,4,8,16,32,64 --precision gpu,exact; fi
tasks=4

work=$root/out/slurm-proof
rm -rf "$work"
mkdir -p "$work"
cluster=$work/cluster
trap 'scripts/slurm/local-cluster.sh stop "$cluster"' EXIT
scripts/slurm/local-cluster.sh start "$cluster"
export SLURM_CONF=$cluster/slurm.conf

# The unsharded run, with the cores one array task gets (one), so the walls compare.
echo "prove: unsharded: tessref sweep $scene $* --threads 1"
start=$(date +%s.%N)
"$TESSREF" sweep "$scene" "$@" --threads 1 -o "$work/unsharded" 2>"$work/unsharded.log"
unsharded_s=$(echo "$(date +%s.%N) - $start" | bc)

echo "prove: sbatch --array=0-$((tasks - 1)) scripts/slurm/sweep.sbatch"
start=$(date +%s.%N)
job=$(sbatch --parsable --array=0-$((tasks - 1)) --output="$work/task-%a.log" \
      scripts/slurm/sweep.sbatch "$work/array" "$scene" "$@")
# Wait for every task to leave the queue, then require each to have completed.
while squeue -h -j "$job" 2>/dev/null | grep -q .; do sleep 1; done
array_s=$(echo "$(date +%s.%N) - $start" | bc)
for ((i = 0; i < tasks; i++)); do
    state=$(scontrol show job "${job}_$i" 2>/dev/null | grep -o 'JobState=[A-Z]*' | head -1 || true)
    if [[ ! -f "$work/array/shard-$i/sweep.csv" ]]; then
        echo "prove: task $i wrote no sweep.csv ($state); its log:" >&2
        cat "$work/task-$i.log" >&2 || true
        exit 1
    fi
done
"$TESSREF" sweep merge "$work"/array/shard-* -o "$work/merged"

# Compare: the CSV without its timing columns, and the pictures byte for byte.
strip_timing() {
    awk -F, 'NR == 1 { for (i = 1; i <= NF; ++i) keep[i] = ($i !~ /_ms$/) }
             { line = ""; for (i = 1; i <= NF; ++i) if (keep[i]) line = line (line == "" ? "" : ",") $i; print line }' "$1"
}
status=0
if ! diff <(strip_timing "$work/unsharded/sweep.csv") <(strip_timing "$work/merged/sweep.csv") >"$work/csv.diff"; then
    echo "prove: FAIL: sweep.csv differs beyond the timing columns ($work/csv.diff)" >&2
    status=1
fi
if ! diff -r "$work/unsharded/images" "$work/merged/images" >"$work/images.diff"; then
    echo "prove: FAIL: the pictures differ ($work/images.diff)" >&2
    status=1
fi
rows=$(($(wc -l <"$work/merged/sweep.csv") - 1))
printf 'prove: %d rows; unsharded %.1f s (1 thread); %d-task array %.1f s (%d CPUs); merged result %s\n' \
    "$rows" "$unsharded_s" "$tasks" "$array_s" "$(nproc)" "$([[ $status -eq 0 ]] && echo identical || echo DIFFERENT)"
exit $status
