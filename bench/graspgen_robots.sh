#!/usr/bin/env bash
# Grasps for each robot's own gripper: `generate-grasps --joints --robot R` on the example
# cabinet (examples/objects), then the open and close tasks (examples/open_close) with robot R,
# once with R's own joint grasps and once with the bundled droid ones, over N episode attempts
# each (every attempt an episode, cameras off, one worker).
#
#   bench/graspgen_robots.sh [BUILD_DIR] [EPISODES] [ROBOTS...]
#
# Defaults: build/, 50 episodes, robots franka_droid xarm7; SEED=1 in the environment picks
# the datagen and generation seed. Prints the generation time per robot and one row per
# (robot, task, grasps). The configs are the examples' with only the grasp library (and, for
# own grasps, its path) and robot_config.name changed.
set -euo pipefail

root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build="${1:-$root/build}"
episodes="${2:-50}"
shift $(( $# > 2 ? 2 : $# ))
robots=("$@")
[[ ${#robots[@]} -gt 0 ]] || robots=(franka_droid xarm7)
seed="${SEED:-1}"
cli="$build/apps/mlspaces/mlspaces"
py="$root/.venv/bin/python"
[[ -x "$cli" ]] || { echo "graspgen_robots: missing $cli (build it first)" >&2; exit 1; }
work="$(mktemp -d "${TMPDIR:-/tmp}/mlspaces_graspgen_robots_XXXXXX")"
trap 'rm -rf "$work"' EXIT

# The example config for task $1 with the grasp library at $2 (absolute paths throughout).
config() {
  "$py" - "$root/examples/open_close/datagen_$1.yaml" "$2" "$root" <<'PY'
import re, sys
src, grasps, root = sys.argv[1:]
s = open(src).read()
s = s.replace("path: ../objects}", "path: %s/examples/objects}" % root, 1)
s = s.replace("{name: example_objects_grasps, path: ../objects,",
              "{name: grasps, path: %s," % grasps)
s = re.sub(r"scene_xml_paths: \[([^\]]*)\]", lambda m: "scene_xml_paths: [%s]" % ", ".join(
    "%s/examples/open_close/%s" % (root, x.strip()) for x in m.group(1).split(",")), s)
assert "../objects" not in s, s
print(s)
PY
}

printf '%-14s %-6s %-6s %9s %9s %8s %s\n' robot task grasps episodes successes rate outcomes
for robot in "${robots[@]}"; do
  own="$work/grasps_$robot"
  start="$(date +%s.%N)"
  "$cli" generate-grasps "$root/examples/objects" --joints --robot "$robot" -o "$own" -q \
    --seed "$seed" > "$work/gen_$robot.txt"
  end="$(date +%s.%N)"
  gen_s="$("$py" -c "print('%.1f' % ($end - $start))")"
  for task in open close; do
    for grasps in own droid; do
      lib="$root/examples/objects"
      [[ $grasps == own ]] && lib="$own"
      config "$task" "$lib" > "$work/$robot-$task-$grasps.yaml"
      out="$work/$robot-$task-$grasps"
      "$cli" datagen "$work/$robot-$task-$grasps.yaml" -q --seed "$seed" --episodes "$episodes" \
        --output "$out" --set robot_config.name="$robot" --set 'camera_config.cameras=[]' \
        --set filter_for_successful_trajectories=false > "$out.txt"
      "$py" - "$out/journal.jsonl" "$robot" "$task" "$grasps" <<'PY'
import collections, json, sys
path, robot, task, grasps = sys.argv[1:]
lines = [json.loads(l) for l in open(path)]
ok = sum(l["outcome"] == "success" for l in lines)
other = collections.Counter(l["outcome"] for l in lines if l["outcome"] != "success")
print("%-14s %-6s %-6s %9d %9d %7.1f%% %s" % (robot, task, grasps, len(lines), ok,
                                              100.0 * ok / max(len(lines), 1), dict(other) or "-"))
PY
    done
  done
  echo "# $robot: generate-grasps --joints took ${gen_s} s ($(tail -1 "$work/gen_$robot.txt"))"
done
