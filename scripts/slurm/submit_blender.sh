#!/usr/bin/env bash
# Render a .blend with the gradphoton addon as a Slurm job array (docs/distributed.md); the
# addon must be installed and enabled on every node (scripts/setup.sh does it), and OUT must be
# on a file system every node sees.
#
#   Animation, one frame per task:   --frames 1-250
#       task f:  blender -b FILE -E GRADPHOTON -o OUT/frame_#### -F OPEN_EXR_MULTILAYER -f f
#   Still, one seed per task, merged: --seeds 16 [--frame 1]
#       task i:  blender -b FILE --python-expr "<scene.gradphoton.seed = i>" -E GRADPHOTON
#                        -o OUT/seed_i_#### -F OPEN_EXR_MULTILAYER -f FRAME
#       then (--dependency=afterok) gradphoton merge OUT/seed_*.exr -o OUT/merged.exr
#
# Other options: --out DIR, --blender PATH, --gradphoton PATH (for the merge), --partition P,
# --time LIMIT, --cpus N, --sbatch "ARGS" (as scripts/slurm/submit_render.sh).
set -euo pipefail

here="$(cd "$(dirname "$0")" && pwd)"
frames="" seeds="" frame=1 out="slurm-blender-$(date +%Y%m%d-%H%M%S)" blender=blender
gradphoton="$here/../../build/gradphoton" partition="" timelimit="" cpus=1 extra=""
while (($#)); do
  case "$1" in
    --frames) frames="$2"; shift 2 ;;
    --seeds) seeds="$2"; shift 2 ;;
    --frame) frame="$2"; shift 2 ;;
    --out) out="$2"; shift 2 ;;
    --blender) blender="$2"; shift 2 ;;
    --gradphoton) gradphoton="$2"; shift 2 ;;
    --partition) partition="$2"; shift 2 ;;
    --time) timelimit="$2"; shift 2 ;;
    --cpus) cpus="$2"; shift 2 ;;
    --sbatch) extra="$2"; shift 2 ;;
    -*) echo "submit_blender: unknown option '$1'" >&2; exit 2 ;;
    *) break ;;
  esac
done
if (($# != 1)) || { [ -z "$frames" ] && [ -z "$seeds" ]; } || { [ -n "$frames" ] && [ -n "$seeds" ]; }; then
  echo "usage: $0 (--frames A-B | --seeds N [--frame F]) [--out DIR] [...] FILE.blend" >&2
  exit 2
fi
blend="$(cd "$(dirname "$1")" && pwd)/$(basename "$1")"
[ -f "$blend" ] || { echo "submit_blender: no such file '$1'" >&2; exit 1; }
mkdir -p "$out/logs"
out="$(cd "$out" && pwd)"
q() { printf '%q' "$1"; }

common=(--parsable --cpus-per-task="$cpus")
[ -n "$partition" ] && common+=(--partition="$partition")
[ -n "$timelimit" ] && common+=(--time="$timelimit")
# shellcheck disable=SC2206
[ -n "$extra" ] && common+=($extra)

if [ -n "$frames" ]; then
  [[ "$frames" =~ ^[0-9]+-[0-9]+$ ]] || { echo "submit_blender: --frames wants A-B, e.g. 1-250" >&2; exit 2; }
  id="$(sbatch "${common[@]}" --job-name=gradphoton-frames --array="$frames" --output="$out/logs/frame_%a.log" \
    --wrap="$(q "$blender") -b $(q "$blend") -E GRADPHOTON -o $(q "$out")/frame_#### -F OPEN_EXR_MULTILAYER -f \$SLURM_ARRAY_TASK_ID")"
  echo "frame array   ${id%%;*} (frames $frames, logs in $out/logs)"
  echo "frames        $out/frame_####.exr"
  exit 0
fi

[[ "$seeds" =~ ^[1-9][0-9]*$ ]] || { echo "submit_blender: --seeds must be a positive integer" >&2; exit 2; }
[ -x "$gradphoton" ] || { echo "submit_blender: no gradphoton at '$gradphoton' (build it, or pass --gradphoton)" >&2; exit 1; }
gradphoton="$(cd "$(dirname "$gradphoton")" && pwd)/$(basename "$gradphoton")"
set_seed='import bpy; bpy.context.scene.gradphoton.seed = int(__import__("os").environ["SLURM_ARRAY_TASK_ID"])'
array_id="$(sbatch "${common[@]}" --job-name=gradphoton-seeds --array="0-$((seeds - 1))" \
  --output="$out/logs/seed_%a.log" \
  --wrap="$(q "$blender") -b $(q "$blend") --python-expr $(q "$set_seed") -E GRADPHOTON -o $(q "$out")/seed_\${SLURM_ARRAY_TASK_ID}_#### -F OPEN_EXR_MULTILAYER -f $(q "$frame")")"
array_id="${array_id%%;*}"
merge_id="$(sbatch "${common[@]}" --job-name=gradphoton-merge --dependency="afterok:$array_id" \
  --output="$out/logs/merge.log" \
  --wrap="$(q "$gradphoton") merge $(q "$out")/seed_*.exr -o $(q "$out")/merged.exr")"
echo "seed array    $array_id ($seeds tasks, seeds 0-$((seeds - 1)), frame $frame, logs in $out/logs)"
echo "merge job     ${merge_id%%;*} (after every task succeeds)"
echo "merged EXR    $out/merged.exr"
