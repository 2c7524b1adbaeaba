#!/usr/bin/env bash
# CLIP search at MolmoSpaces' scale, one command: builds clip_search_bench (own build dir
# unless MLSPACES_BUILD_DIR is set), writes synthetic float16 features for 131,000 assets x
# (3 views + text) x 768 (805 MB, deterministic seed) into a store under WORK (kept for reruns),
# prints the median exact query latency (with bounds, and the full scan), the single-core
# streaming-read time of the same bytes, approximate latency and recall@50, the same for
# isotropic features (MLSPACES_CLIP_BENCH_SKIP_ISOTROPIC=1 skips them), and then the original's numpy formula
# (molmo_spaces/utils/object_retriever.py + clip_sim) on the same features and queries, with
# its median latency, the speed-up and how far its top-50 agrees with ours.
#   bench/clip_search_bench.sh [WORK]        (default WORK: /tmp/mlspaces_clip_bench)
#   MLSPACES_CLIP_BENCH_ASSETS=N             fewer assets for a quick run
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
WORK="${1:-/tmp/mlspaces_clip_bench}"
ASSETS="${MLSPACES_CLIP_BENCH_ASSETS:-131000}"
BUILD="${MLSPACES_BUILD_DIR:-$ROOT/build}"
PY="${MLSPACES_PYTHON:-$ROOT/.venv/bin/python}"
mkdir -p "$WORK"
if [[ ! -x "$BUILD/bench/clip_search_bench" ]]; then
  MLSPACES_BUILD_DIR="$BUILD" MLSPACES_BUILD_TARGETS='clip_search_bench' "$ROOT/scripts/build.sh" >&2
fi
STORE="$WORK/clip_features_${ASSETS}.mlsc"
# A store left by an older format (another magic) is generated again.
for f in "$STORE" "$WORK/clip_features_${ASSETS}_isotropic.mlsc"; do
  if [[ -f "$f" && "$(head -c 8 "$f")" != "MLSCLIP2" ]]; then rm -f "$f"; fi
done
echo "== synthetic CLIP-like features (decaying spectrum)"
"$BUILD/bench/clip_search_bench" "$STORE" --assets "$ASSETS" --queries 20 --out "$WORK"
if [[ -z "${MLSPACES_CLIP_BENCH_SKIP_ISOTROPIC:-}" ]]; then
  echo "== isotropic features (worst case for the bounds and the approximate pass)"
  MLSPACES_CLIP_BENCH_ISOTROPIC=1 "$BUILD/bench/clip_search_bench" \
    "$WORK/clip_features_${ASSETS}_isotropic.mlsc" --assets "$ASSETS" --queries 20
fi
echo "== the original's numpy formula on the decaying-spectrum features"

"$PY" - "$STORE" "$WORK" <<'PYEOF'
import json, struct, sys, time
import numpy as np

store, work = sys.argv[1], sys.argv[2]
with open(store, "rb") as f:
    head = f.read(64)
n, = struct.unpack_from("<I", head, 12)
views, dim = struct.unpack_from("<II", head, 24)
uids_off, = struct.unpack_from("<Q", head, 40)
rec = np.memmap(store, dtype=np.float16, mode="r", offset=64, shape=(n, views + 1, dim))
# The original keeps img_keys (N,3,768) and txt_keys (N,1,768) float16 arrays in memory.
ik = np.ascontiguousarray(rec[:, :views, :])
tk = np.ascontiguousarray(rec[:, views:, :])
raw = np.fromfile(store, dtype=np.uint8)
table = raw[uids_off:uids_off + 8 * n].view("<u4").reshape(n, 2)
strings_off = (uids_off + 12 * n + 7) // 8 * 8
v = np.array([raw[strings_off + o:strings_off + o + l].tobytes().decode() for o, l in table])
del raw, rec

def clip_sim(clip_img, clip_text, num_views):  # the original's, normalize=False
    res = np.einsum("od,qd->oq", clip_img[:, 0, :], clip_text)
    for i in range(1, num_views):
        res = np.maximum(res, np.einsum("od,qd->oq", clip_img[:, i, :], clip_text))
    return res

def original_query(q, thres=0.5, max_results=50):
    q = q.astype("float16")          # compute_text_clip returns float16
    q = q / np.linalg.norm(q)
    sim = (clip_sim(ik, q[None], 3) + 0.5 * clip_sim(tk, q[None], 1)).flatten()
    mask = sim >= thres
    rank = np.argsort(sim[mask])[::-1][:max_results]
    return v[mask][rank], sim[mask][rank]

queries = np.load(f"{work}/queries.npy")
ours = json.load(open(f"{work}/exact.json"))
times, agree, total, worst = [], 0, 0, 0.0
nq = min(len(queries), 5)
for k in range(nq):
    t0 = time.perf_counter()
    uids, sims = original_query(queries[k])
    times.append((time.perf_counter() - t0) * 1000)
    mine = [u for u, s in ours["top50"][k] if s >= 0.5][:50]
    agree += len(set(mine) & set(uids.tolist()))
    total += len(mine)
    score = {u: s for u, s in ours["top50"][k]}
    worst = max([worst] + [abs(float(s) - score[u]) for u, s in zip(uids, sims) if u in score])
med = sorted(times)[len(times) // 2]
print(f"original numpy formula (float16 einsum, 1 query at a time): median {med:.0f} ms over "
      f"{nq} queries")
print(f"speed-up of the exact query over numpy: {med / ours['exact_ms']:.1f}x")
print(f"numpy vs ours: {agree}/{total} top-50 UIDs shared, max |score diff| {worst:.2e} "
      f"(numpy rounds scores to float16)")
PYEOF
