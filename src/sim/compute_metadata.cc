#include "mlspaces/sim/compute_metadata.h"

#include <algorithm>
#include <mutex>

#include "mlspaces/core/error.h"
#include "mlspaces/core/files.h"
#include "mlspaces/core/parallel.h"
#include "mlspaces/sim/mujoco_handlers.h"

namespace mlspaces::sim {

namespace fs = std::filesystem;

Json MakeComputedMetadata(const Json& source, const AssetFacts& facts) {
  Json out = source;
  if (!out.contains("mass")) out["mass"] = facts.mass;
  if (!out.contains("boundingBox")) {
    out["boundingBox"] = {
        {"x", facts.bounding_box[0]}, {"y", facts.bounding_box[1]}, {"z", facts.bounding_box[2]}};
  }
  out["aabb"] = {{"min", {facts.aabb_min[0], facts.aabb_min[1], facts.aabb_min[2]}},
                 {"max", {facts.aabb_max[0], facts.aabb_max[1], facts.aabb_max[2]}}};
  return out;
}

ComputeMetadataReport ComputeAssetMetadata(const fs::path& dir, const AssetIndexOptions& options,
                                           const ComputeMetadataOptions& compute) {
  InstallMujocoHandlers();
  const fs::path root = fs::absolute(dir).lexically_normal();
  ComputeMetadataReport report;
  const fs::path output = AssetIndexOutputPath(root, options);
  std::error_code ec;
  IndexReport scan;
  AssetIndex plain = BuildAssetIndex(root, options, &scan, /*use_computed=*/false);

  struct Work {
    std::string uid;
    fs::path xml, json, computed;
  };
  std::vector<Work> work;
  for (const auto& [uid, e] : plain.entries) {
    Work w{uid, root / e.object_path, root / e.metadata_path, {}};
    w.computed = w.xml.parent_path() / (uid + "_computed.json");
    if (!options.overwrite && fs::exists(w.computed, ec)) {
      ++report.reused;
      continue;
    }
    work.push_back(std::move(w));
  }

  std::mutex mu;
  size_t done = 0;
  ParallelFor(work.size(), compute.threads, [&](size_t i) {
    const Work& w = work[i];
    std::string failure;
    try {
      Json source = ParseJsonFile(w.json);
      AssetFacts facts = ComputeAssetFacts(w.xml, /*physics_only=*/true);
      // No fsync per ~300-byte file (4-8 ms each on this machine's disk, several times the
      // compile): the file system is synced once below, before the index is written.
      WriteFileAtomic(w.computed, DumpJsonIndent4(MakeComputedMetadata(source, facts)),
                      /*sync=*/false);
    } catch (const std::exception& e) {
      failure = e.what();
    }
    std::lock_guard<std::mutex> lock(mu);
    if (failure.empty()) {
      ++report.computed;
    } else {
      report.failures.push_back(Diagnostic{"", "", failure, w.uid});
    }
    ++done;
    if (compute.progress) compute.progress(done, work.size());
  });
  std::sort(report.failures.begin(), report.failures.end(),
            [](const AssetFailure& a, const AssetFailure& b) { return a.uid < b.uid; });

  if (report.computed > 0) SyncFileSystem(root);

  report.index.output = output;
  report.index.warnings = scan.warnings;
  AssetIndex index = BuildAssetIndex(root, options, nullptr, /*use_computed=*/true);
  report.index.count = index.entries.size();
  WriteFileAtomic(output, index.Serialize());
  return report;
}

}  // namespace mlspaces::sim
