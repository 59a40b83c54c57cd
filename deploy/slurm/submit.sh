#!/usr/bin/env bash
# Submits a sharded patchvis bake to Slurm: one tiling job, a job array of SHARDS bakes that
# starts when the tiling succeeded, and a merge job that starts when every shard succeeded
# (--dependency=afterok). Prints the three job ids, one a line (tile, array, merge).
#
#   deploy/slurm/submit.sh INPUT OUTPUT.pvis SHARDS [bake flags...]
#
# INPUT, OUTPUT and the work directory must be on a file system every node sees. The bake
# flags go to every shard (and those that decide the tiling, --patches, --memory, --tiling
# and --fov, to the tiling job), so the merged file is byte for byte the single bake's with
# these flags. Environment:
#   PATCHVIS        the patchvis binary on the nodes [patchvis, from PATH]
#   PATCHVIS_WORK   directory for the tiling, parts and logs [OUTPUT.shards]
#   SBATCH_FLAGS    extra sbatch options for all three jobs, e.g. "--partition=bake"
set -euo pipefail

if [ $# -lt 3 ]; then
    echo "usage: $0 INPUT OUTPUT.pvis SHARDS [bake flags...]" >&2
    exit 2
fi
input=$(realpath "$1")
output=$(realpath -m "$2")
shards=$3
shift 3
case $shards in
    '' | *[!0-9]* | 0)
        echo "error: SHARDS must be a whole number of at least 1, not '$shards'" >&2
        exit 2
        ;;
esac
here=$(dirname "$(realpath "$0")")
work=$(realpath -m "${PATCHVIS_WORK:-$output.shards}")
mkdir -p "$work/logs"

# The flags that decide the tiling go to `patchvis tile` too.
tile_flags=()
bake_flags=("$@")
while [ $# -gt 0 ]; do
    case $1 in
        --patches | --memory | --tiling | --fov)
            tile_flags+=("$1" "${2:?$1 needs a value}")
            shift 2
            ;;
        --patches=* | --memory=* | --tiling=* | --fov=*)
            tile_flags+=("$1")
            shift
            ;;
        *) shift ;;
    esac
done

# The job scripts read these (sbatch --export=ALL); arrays travel shell-quoted.
export PATCHVIS="${PATCHVIS:-patchvis}"
export PATCHVIS_INPUT="$input" PATCHVIS_OUTPUT="$output" PATCHVIS_WORK="$work"
export PATCHVIS_SHARDS="$shards"
export PATCHVIS_TILE_FLAGS="${tile_flags[*]@Q}"
export PATCHVIS_BAKE_FLAGS="${bake_flags[*]@Q}"
read -r -a extra <<<"${SBATCH_FLAGS:-}"

tile=$(sbatch --parsable --export=ALL "${extra[@]}" --job-name=patchvis-tile \
    --output="$work/logs/tile.out" "$here/tile.sbatch")
tile=${tile%%;*}
array=$(sbatch --parsable --export=ALL "${extra[@]}" --job-name=patchvis-shard \
    --array="0-$((shards - 1))" --dependency="afterok:$tile" --kill-on-invalid-dep=yes \
    --output="$work/logs/shard-%a.out" "$here/shard.sbatch")
array=${array%%;*}
merge=$(sbatch --parsable --export=ALL "${extra[@]}" --job-name=patchvis-merge \
    --dependency="afterok:$array" --kill-on-invalid-dep=yes \
    --output="$work/logs/merge.out" "$here/merge.sbatch")
merge=${merge%%;*}
printf '%s\n%s\n%s\n' "$tile" "$array" "$merge"
