#!/usr/bin/env bash
# Quality figure: success rate of the tutorial config (examples/custom_assets/datagen.yaml,
# action noise and init noise on, as configured) over N episode attempts, for several seeds.
# Target: >= 90% of attempts succeed.
#
#   bench/datagen_quality.sh [BUILD_DIR] [EPISODES] [SEEDS...]
#
# Defaults: build/, 100 episodes, seeds 1 2 3. Each seed is one `mlspaces datagen` run with
# filter_for_successful_trajectories off, so every attempt is an episode (the success rate
# is not inflated by retrying failed ones), written to a temp folder.
set -euo pipefail

root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build="${1:-$root/build}"
episodes="${2:-100}"
shift $(( $# > 2 ? 2 : $# ))
seeds=("$@")
[[ ${#seeds[@]} -gt 0 ]] || seeds=(1 2 3)
cli="$build/apps/mlspaces/mlspaces"
[[ -x "$cli" ]] || { echo "datagen_quality: missing $cli (build it first)" >&2; exit 1; }
work="$(mktemp -d "${TMPDIR:-/tmp}/mlspaces_quality_XXXXXX")"
trap 'rm -rf "$work"' EXIT

printf '%-6s %9s %9s %8s %s\n' seed episodes successes rate outcomes
for seed in "${seeds[@]}"; do
  out="$work/seed_$seed"
  "$cli" datagen "$root/examples/custom_assets/datagen.yaml" -q --seed "$seed" \
    --episodes "$episodes" --output "$out" \
    --set task_sampler_config.episodes_per_batch="$episodes" \
    --set filter_for_successful_trajectories=false > "$out.txt"
  "$root/.venv/bin/python" - "$out/journal.jsonl" "$seed" <<'PY'
import collections, json, sys
lines = [json.loads(l) for l in open(sys.argv[1])]
n = len(lines)
ok = sum(l["outcome"] == "success" for l in lines)
other = collections.Counter(l["outcome"] for l in lines if l["outcome"] != "success")
print("%-6s %9d %9d %7.1f%% %s" % (sys.argv[2], n, ok, 100.0 * ok / n, dict(other) or "-"))
PY
done
