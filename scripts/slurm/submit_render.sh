#!/usr/bin/env bash
# Render one scene as a Slurm job array of independent-seed runs, then merge them
# (docs/distributed.md). Task i runs
#     gradphoton render SCENE [RENDER ARGS] --seed i -o OUT/run_i.exr
# and a merge job (--dependency=afterok on the whole array) runs
#     gradphoton merge OUT/run_*.exr -o OUT/merged.exr
# Prints the job ids and where the merged EXR will be. OUT must be on a file system every node
# sees (the merge job reads what the tasks wrote).
#
#   scripts/slurm/submit_render.sh --tasks 16 --out /shared/renders/torus -- \
#       scenes/torus-glass.json --method pt --time 600 --width 960 --height 540
#
# Options (before --): --tasks N (default 4), --out DIR (default slurm-render-<date>),
# --gradphoton PATH (default: this checkout's build/gradphoton), --partition P, --time LIMIT
# (Slurm's time limit per task, e.g. 00:15:00), --cpus N (CPUs per task, default 1; the render
# uses them all: pass --threads 0), --sbatch "ARGS" (anything else for sbatch, e.g. "--account=x").
set -euo pipefail

here="$(cd "$(dirname "$0")" && pwd)"
tasks=4 out="slurm-render-$(date +%Y%m%d-%H%M%S)" gradphoton="$here/../../build/gradphoton"
partition="" timelimit="" cpus=1 extra=""
while (($#)); do
  case "$1" in
    --tasks) tasks="$2"; shift 2 ;;
    --out) out="$2"; shift 2 ;;
    --gradphoton) gradphoton="$2"; shift 2 ;;
    --partition) partition="$2"; shift 2 ;;
    --time) timelimit="$2"; shift 2 ;;
    --cpus) cpus="$2"; shift 2 ;;
    --sbatch) extra="$2"; shift 2 ;;
    --) shift; break ;;
    *) echo "submit_render: unknown option '$1' (render arguments go after --)" >&2; exit 2 ;;
  esac
done
(($# >= 1)) || { echo "usage: $0 [--tasks N] [--out DIR] [...] -- SCENE [gradphoton render args]" >&2; exit 2; }
[[ "$tasks" =~ ^[1-9][0-9]*$ ]] || { echo "submit_render: --tasks must be a positive integer" >&2; exit 2; }
for a in "$@"; do
  case "$a" in --seed|--seed=*|-o|--output|--output=*) echo "submit_render: '$a' is set per task; leave it out" >&2; exit 2 ;; esac
done
[ -x "$gradphoton" ] || { echo "submit_render: no gradphoton at '$gradphoton' (build it, or pass --gradphoton)" >&2; exit 1; }
gradphoton="$(cd "$(dirname "$gradphoton")" && pwd)/$(basename "$gradphoton")"
scene="$(cd "$(dirname "$1")" && pwd)/$(basename "$1")"
shift
mkdir -p "$out/logs"
out="$(cd "$out" && pwd)"

common=(--parsable --cpus-per-task="$cpus")
[ -n "$partition" ] && common+=(--partition="$partition")
[ -n "$timelimit" ] && common+=(--time="$timelimit")
# shellcheck disable=SC2206
[ -n "$extra" ] && common+=($extra)

render_cmd="$(printf '%q ' "$gradphoton" render "$scene" "$@")"
array_id="$(sbatch "${common[@]}" --job-name=gradphoton-render --array="0-$((tasks - 1))" \
  --output="$out/logs/run_%a.log" \
  --wrap="$render_cmd --seed \$SLURM_ARRAY_TASK_ID -o $(printf '%q' "$out")/run_\$SLURM_ARRAY_TASK_ID.exr")"
array_id="${array_id%%;*}"
merge_id="$(sbatch "${common[@]}" --job-name=gradphoton-merge --dependency="afterok:$array_id" \
  --output="$out/logs/merge.log" \
  --wrap="$(printf '%q ' "$gradphoton" merge) $(printf '%q' "$out")/run_*.exr -o $(printf '%q' "$out")/merged.exr")"
merge_id="${merge_id%%;*}"

echo "render array  $array_id ($tasks tasks, seeds 0-$((tasks - 1)), logs in $out/logs)"
echo "merge job     $merge_id (after every task succeeds)"
echo "merged EXR    $out/merged.exr"
