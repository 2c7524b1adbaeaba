#!/usr/bin/env bash
# Per-task benchmark: success rate and episodes per hour of the open / close examples
# (examples/open_close/datagen_{open,close}.yaml) and the pick-and-place ones
# (examples/pick_and_place/datagen{,_next_to,_color}.yaml: tasks pick_and_place,
# pick_and_place_next_to, pick_and_place_color), cameras off, over N episode attempts per
# task, with the failure reasons by class (journal outcome, and per joint / receptacle).
#
#   bench/tasks_bench.sh [BUILD_DIR] [EPISODES] [TASKS...]
#
# Defaults: build/, 100 episodes, tasks open close; SEED=1 in the environment picks the seed,
# ROBOT=<name> changes robot_config.name. Each task is one `mlspaces datagen` run with
# filter_for_successful_trajectories off, so every attempt is an episode (as
# bench/robots_bench.sh), written to a temp folder; outcomes come from its journal.jsonl.
# Episodes per hour = episodes / wall time of the run (process start to exit; scene building
# included), one worker.
set -euo pipefail

root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build="${1:-$root/build}"
episodes="${2:-100}"
shift $(( $# > 2 ? 2 : $# ))
tasks=("$@")
[[ ${#tasks[@]} -gt 0 ]] || tasks=(open close)
seed="${SEED:-1}"
robot="${ROBOT:-franka_droid}"
cli="$build/apps/mlspaces/mlspaces"
[[ -x "$cli" ]] || { echo "tasks_bench: missing $cli (build it first)" >&2; exit 1; }
work="$(mktemp -d "${TMPDIR:-/tmp}/mlspaces_tasks_XXXXXX")"
trap 'rm -rf "$work"' EXIT

printf '%-22s %-13s %5s %9s %9s %8s %9s %10s %s\n' task robot seed episodes successes rate \
  wall_s episodes/h "failures by class (outcome/joint)"
for task in "${tasks[@]}"; do
  out="$work/$task"
  start="$(date +%s.%N)"
  case "$task" in
    pick_and_place) yaml="$root/examples/pick_and_place/datagen.yaml" ;;
    pick_and_place_*) yaml="$root/examples/pick_and_place/datagen_${task#pick_and_place_}.yaml" ;;
    *) yaml="$root/examples/open_close/datagen_$task.yaml" ;;
  esac
  "$cli" datagen "$yaml" -q --seed "$seed" \
    --episodes "$episodes" --output "$out" \
    --set robot_config.name="$robot" \
    --set 'camera_config.cameras=[]' \
    --set task_sampler_config.episodes_per_batch="$episodes" \
    --set filter_for_successful_trajectories=false > "$out.txt"
  end="$(date +%s.%N)"
  "$root/.venv/bin/python" - "$out/journal.jsonl" "$task" "$robot" "$seed" "$start" "$end" <<'PY'
import collections, json, sys
path, task, robot, seed, start, end = sys.argv[1:]
lines = [json.loads(l) for l in open(path)]
n = len(lines)
ok = sum(l["outcome"] == "success" for l in lines)
def part(l):  # the joint (open / close) or the receptacle (pick-and-place)
    return l.get("extra", {}).get("joint") or l.get("extra", {}).get("place_receptacle", "?")
per_joint = collections.Counter(part(l) for l in lines)
ok_joint = collections.Counter(part(l) for l in lines if l["outcome"] == "success")
fails = collections.Counter("%s/%s" % (l["outcome"], part(l))
                            for l in lines if l["outcome"] != "success")
wall = float(end) - float(start)
print("%-22s %-13s %5s %9d %9d %7.1f%% %9.1f %10.0f %s" % (
    task, robot, seed, n, ok, 100.0 * ok / max(n, 1), wall, 3600.0 * n / wall,
    dict(fails) or "-"))
print("       per joint / receptacle: " + ", ".join("%s %d/%d" % (j, ok_joint[j], c) for j, c in sorted(per_joint.items())))
PY
done
