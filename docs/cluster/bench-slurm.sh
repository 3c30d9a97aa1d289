#!/usr/bin/env bash
# One `rsl bench` split over a Slurm job array, then joined by a job that waits for it.
#
#   docs/cluster/bench-slurm.sh SHARDS OUT CACHE SCENE... [-- BENCH-OPTIONS...]
#
# OUT and CACHE must be on a file system every node sees. Each array element runs
# `rsl bench SCENE... --out OUT --cache CACHE --shard K/SHARDS BENCH-OPTIONS...`; a failed or
# preempted element can be resubmitted (`scontrol requeue`, or this script again): it measures
# only what it had not finished. The merge job then writes OUT/results.csv and OUT/report.md.
# `rsl` must be on the nodes' PATH (or set RSL=/path/to/rsl).
set -euo pipefail
if [ $# -lt 4 ]; then
  sed -n '2,10p' "$0" >&2
  exit 2
fi
shards=$1 out=$2 cache=$3
shift 3
scenes=() options=()
while [ $# -gt 0 ] && [ "$1" != "--" ]; do scenes+=("$1"); shift; done
[ $# -gt 0 ] && shift
options=("$@")
rsl=${RSL:-rsl}
quote() { printf '%q ' "$@"; }
common="$(quote "$rsl" bench "${scenes[@]}" --out "$out" --cache "$cache" "${options[@]}")"
mkdir -p "$out" "$cache"
array=$(sbatch --parsable --job-name=rsl-bench --array="0-$((shards - 1))" \
  --output="$out/slurm-%A_%a.log" \
  --wrap="$common --shard \$SLURM_ARRAY_TASK_ID/$shards")
sbatch --parsable --job-name=rsl-bench-merge --dependency="afterany:$array" \
  --output="$out/slurm-merge-%j.log" --wrap="$common --merge"
echo "submitted array $array ($shards shards) and its merge; results in $out" >&2
