#!/usr/bin/env bash
# Per-robot benchmark: success rate and episodes per hour of the tutorial config
# (examples/custom_assets/datagen.yaml) with only robot_config.name changed, cameras off
# (camera_config.cameras=[]), over N episode attempts per robot.
#
#   bench/robots_bench.sh [BUILD_DIR] [EPISODES] [ROBOTS...]
#
# Defaults: build/, 100 episodes, robots franka_droid xarm7; SEED=1 in the environment picks
# the seed. Each robot is one `mlspaces datagen` run with filter_for_successful_trajectories
# off, so every attempt is an episode (as bench/datagen_quality.sh), written to a temp folder;
# outcomes come from its journal.jsonl. Episodes per hour = episodes / wall time of the run
# (process start to exit, `date +%s.%N`; scene building included), one worker.
set -euo pipefail

root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build="${1:-$root/build}"
episodes="${2:-100}"
shift $(( $# > 2 ? 2 : $# ))
robots=("$@")
[[ ${#robots[@]} -gt 0 ]] || robots=(franka_droid xarm7)
seed="${SEED:-1}"
cli="$build/apps/mlspaces/mlspaces"
[[ -x "$cli" ]] || { echo "robots_bench: missing $cli (build it first)" >&2; exit 1; }
work="$(mktemp -d "${TMPDIR:-/tmp}/mlspaces_robots_XXXXXX")"
trap 'rm -rf "$work"' EXIT

printf '%-14s %5s %9s %9s %8s %9s %10s %s\n' robot seed episodes successes rate wall_s \
  episodes/h outcomes
for robot in "${robots[@]}"; do
  out="$work/$robot"
  start="$(date +%s.%N)"
  "$cli" datagen "$root/examples/custom_assets/datagen.yaml" -q --seed "$seed" \
    --episodes "$episodes" --output "$out" \
    --set robot_config.name="$robot" \
    --set 'camera_config.cameras=[]' \
    --set task_sampler_config.episodes_per_batch="$episodes" \
    --set filter_for_successful_trajectories=false > "$out.txt"
  end="$(date +%s.%N)"
  "$root/.venv/bin/python" - "$out/journal.jsonl" "$robot" "$seed" "$start" "$end" <<'PY'
import collections, json, sys
path, robot, seed, start, end = sys.argv[1:]
lines = [json.loads(l) for l in open(path)]
n = len(lines)
ok = sum(l["outcome"] == "success" for l in lines)
other = collections.Counter(l["outcome"] for l in lines if l["outcome"] != "success")
wall = float(end) - float(start)
print("%-14s %5s %9d %9d %7.1f%% %9.1f %10.0f %s" % (
    robot, seed, n, ok, 100.0 * ok / max(n, 1), wall, 3600.0 * n / wall, dict(other) or "-"))
PY
done
