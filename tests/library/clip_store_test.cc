// The CLIP feature store: writer/reader round trip, damaged files, exact scores against a
// double-precision brute force, ties, threshold, top-k, filters, threads and the approximate
// pass.
#include "mlspaces/library/clip_store.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <random>
#include <string>
#include <tuple>
#include <vector>

#include "mlspaces/core/error.h"
#include "mlspaces/core/files.h"
#include "test_util.h"

namespace mlspaces {
namespace {
namespace fs = std::filesystem;

struct Features {
  std::vector<std::string> uids;
  std::vector<float> img, text;  // n*views*dim, n*dim (not normalised)
};

// Clustered features (like real CLIP embeddings: objects of a kind point the same way).
Features MakeFeatures(size_t n, size_t views, size_t dim, uint64_t seed, size_t clusters = 20) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<float> normal(0.0f, 1.0f);
  std::vector<float> centres(clusters * dim);
  for (float& x : centres) x = normal(rng);
  Features f;
  for (size_t i = 0; i < n; ++i) {
    f.uids.push_back("uid_" + std::to_string((i * 7919) % n));
    const float* c = centres.data() + (i % clusters) * dim;
    for (size_t v = 0; v <= views; ++v) {
      for (size_t j = 0; j < dim; ++j) {
        const float x = c[j] + 0.7f * normal(rng);
        (v < views ? f.img : f.text).push_back(x * 3.0f);  // any length: the writer normalises
      }
    }
  }
  return f;
}

fs::path WriteStore(const fs::path& file, const Features& f, size_t views, size_t dim) {
  ClipStoreWriter writer(file, views, dim);
  for (size_t i = 0; i < f.uids.size(); ++i) {
    writer.Add(f.uids[i], std::span(f.img).subspan(i * views * dim, views * dim),
               std::span(f.text).subspan(i * dim, dim));
  }
  writer.Finish();
  return file;
}

// The original's formula in double precision over the stored (float16) vectors.
std::vector<std::pair<double, std::string>> Reference(const ClipStore& store,
                                                      std::span<const float> query, double thres,
                                                      size_t k) {
  double norm = 0;
  for (float x : query) norm += double{x} * x;
  norm = std::sqrt(norm);
  std::vector<std::pair<double, std::string>> all;
  const size_t dim = store.dim();
  for (size_t r = 0; r < store.size(); ++r) {
    const std::vector<float> img = store.ImageFeatures(r), text = store.TextFeature(r);
    double best = -1e9;
    for (size_t v = 0; v < store.views(); ++v) {
      double d = 0;
      for (size_t j = 0; j < dim; ++j) d += double{img[v * dim + j]} * query[j] / norm;
      best = std::max(best, d);
    }
    double t = 0;
    for (size_t j = 0; j < dim; ++j) t += double{text[j]} * query[j] / norm;
    const double score = best + 0.5 * t;
    if (score >= thres) all.emplace_back(score, std::string(store.uid(r)));
  }
  std::sort(all.begin(), all.end(), [](const auto& a, const auto& b) {
    return a.first != b.first ? a.first > b.first : a.second < b.second;
  });
  if (all.size() > k) all.resize(k);
  return all;
}

class ClipStoreTest : public ::testing::Test {
 protected:
  static constexpr size_t kViews = 3, kDim = 64, kN = 600;
  void SetUp() override {
    features_ = MakeFeatures(kN, kViews, kDim, 7);
    path_ = WriteStore(dir_.path() / "clip_features.mlsc", features_, kViews, kDim);
    store_ = ClipStore::Open(path_);
  }
  // A query near asset i's first view.
  std::vector<float> QueryNear(size_t i) const {
    std::vector<float> q(features_.img.begin() + static_cast<ptrdiff_t>(i * kViews * kDim),
                         features_.img.begin() + static_cast<ptrdiff_t>(i * kViews * kDim + kDim));
    for (size_t j = 0; j < kDim; ++j) q[j] += 0.3f * std::sin(static_cast<float>(j));
    return q;
  }
  testing::TempDir dir_;
  Features features_;
  fs::path path_;
  std::shared_ptr<const ClipStore> store_;
};

TEST_F(ClipStoreTest, RoundTripKeepsUidsAndNormalisedVectors) {
  ASSERT_EQ(store_->size(), kN);
  EXPECT_EQ(store_->views(), kViews);
  EXPECT_EQ(store_->dim(), kDim);
  EXPECT_TRUE(store_->has_approximate());
  store_->Check();
  for (size_t i = 0; i < kN; i += 37) {
    const auto row = store_->Find(features_.uids[i]);
    ASSERT_TRUE(row.has_value()) << features_.uids[i];
    EXPECT_EQ(*row, i);
    EXPECT_EQ(store_->uid(i), features_.uids[i]);
    const std::vector<float> img = store_->ImageFeatures(i);
    for (size_t v = 0; v < kViews; ++v) {
      double norm = 0, dot = 0, ref_norm = 0;
      for (size_t j = 0; j < kDim; ++j) {
        const double x = features_.img[(i * kViews + v) * kDim + j];
        norm += double{img[v * kDim + j]} * img[v * kDim + j];
        dot += x * img[v * kDim + j];
        ref_norm += x * x;
      }
      EXPECT_NEAR(norm, 1.0, 2e-3);
      EXPECT_NEAR(dot / std::sqrt(ref_norm), 1.0, 2e-3);  // same direction
    }
  }
  EXPECT_FALSE(store_->Find("uid_missing").has_value());
  EXPECT_FALSE(store_->Find("").has_value());
}

TEST_F(ClipStoreTest, SameInputGivesIdenticalFile) {
  const fs::path again = WriteStore(dir_.path() / "again.mlsc", features_, kViews, kDim);
  EXPECT_EQ(ReadFile(again), ReadFile(path_));
}

TEST_F(ClipStoreTest, ExactScoresMatchDoubleReference) {
  for (size_t i : {0, 5, 123, 599}) {
    const std::vector<float> q = QueryNear(i);
    for (float thres : {-10.0f, 0.5f, 0.9f}) {
      for (size_t k : {1, 10, 50, 1000}) {
        ClipSearchOptions options;
        options.top_k = k;
        options.threshold = thres;
        const std::vector<ClipHit> hits = store_->Search(q, options);
        const auto ref = Reference(*store_, q, thres, k);
        ASSERT_EQ(hits.size(), ref.size()) << "query " << i << " thres " << thres << " k " << k;
        for (size_t h = 0; h < hits.size(); ++h) {
          EXPECT_NEAR(hits[h].score, ref[h].first, 1e-5);
          if (h + 1 < hits.size()) {
            EXPECT_GE(hits[h].score, hits[h + 1].score);
          }
          // Same UID unless the reference itself has a near-tie here.
          const bool near_tie = (h > 0 && ref[h - 1].first - ref[h].first < 1e-5) ||
                                (h + 1 < ref.size() && ref[h].first - ref[h + 1].first < 1e-5);
          if (!near_tie) {
            EXPECT_EQ(hits[h].uid, ref[h].second);
          }
        }
        for (const ClipHit& hit : hits) EXPECT_GE(hit.score, thres);
      }
    }
  }
}

TEST_F(ClipStoreTest, ThreadsAndApproximateWithAllCandidatesGiveTheExactAnswer) {
  const std::vector<float> q = QueryNear(42);
  ClipSearchOptions exact;
  exact.threshold = -10;
  exact.top_k = 100;
  const auto one = store_->Search(q, exact);
  ClipSearchOptions threaded = exact;
  threaded.threads = 3;
  ClipSearchOptions approx = exact;
  approx.approximate = true;
  approx.candidates = kN;
  for (const auto& other : {store_->Search(q, threaded), store_->Search(q, approx)}) {
    ASSERT_EQ(other.size(), one.size());
    for (size_t h = 0; h < one.size(); ++h) {
      EXPECT_EQ(other[h].uid, one[h].uid);
      EXPECT_EQ(other[h].score, one[h].score);
    }
  }
}

TEST_F(ClipStoreTest, ApproximateRecallOnClusteredFeatures) {
  size_t found = 0, total = 0;
  for (size_t i = 0; i < 20; ++i) {
    const std::vector<float> q = QueryNear(i * 29);
    ClipSearchOptions exact;
    exact.threshold = -10;
    exact.top_k = 20;
    ClipSearchOptions approx = exact;
    approx.approximate = true;
    approx.candidates = 60;
    const auto a = store_->Search(q, exact), b = store_->Search(q, approx);
    for (const ClipHit& hit : a) {
      total += 1;
      found += std::any_of(b.begin(), b.end(), [&](const ClipHit& x) { return x.uid == hit.uid; });
    }
  }
  EXPECT_GE(static_cast<double>(found) / static_cast<double>(total), 0.9);
}

TEST_F(ClipStoreTest, TiesAreOrderedByUid) {
  // Four assets with identical features, added in descending UID order.
  Features f;
  const std::vector<float> img(kViews * kDim, 1.0f), text(kDim, 1.0f);
  for (const char* uid : {"d", "c", "b", "a"}) {
    f.uids.emplace_back(uid);
    f.img.insert(f.img.end(), img.begin(), img.end());
    f.text.insert(f.text.end(), text.begin(), text.end());
  }
  auto store = ClipStore::Open(WriteStore(dir_.path() / "ties.mlsc", f, kViews, kDim));
  ClipSearchOptions options;
  options.top_k = 3;
  const auto hits = store->Search(text, options);
  ASSERT_EQ(hits.size(), 3u);
  EXPECT_EQ(hits[0].uid, "a");
  EXPECT_EQ(hits[1].uid, "b");
  EXPECT_EQ(hits[2].uid, "c");
  EXPECT_NEAR(hits[0].score, 1.5, 1e-3);
  EXPECT_EQ(hits[0].score, hits[2].score);
}

// Exact queries prune with per-asset upper bounds; the answer must be the full scan's, bit for
// bit (UIDs, scores, order), whatever the data: clustered (tight bounds), isotropic in more
// dimensions than the bound codes hold (loose bounds), queries equal to stored vectors, many
// exact ties, filters and thresholds that cut everything.
void ExpectSameAsFullScan(const ClipStore& store, std::span<const float> q, size_t k, float thres,
                          const std::string& what, size_t* scored_out = nullptr,
                          std::function<bool(size_t)> keep = {}) {
  ClipSearchOptions bounded;
  bounded.top_k = k;
  bounded.threshold = thres;
  bounded.keep = std::move(keep);
  size_t scored = 0, full_scored = 0;
  bounded.scored = &scored;
  ClipSearchOptions full = bounded;
  full.full_scan = true;
  full.scored = &full_scored;
  const auto a = store.Search(q, bounded), b = store.Search(q, full);
  EXPECT_EQ(full_scored, store.size()) << what;
  EXPECT_LE(scored, store.size()) << what;
  ASSERT_EQ(a.size(), b.size()) << what << " k " << k << " thres " << thres;
  for (size_t h = 0; h < a.size(); ++h) {
    EXPECT_EQ(a[h].uid, b[h].uid) << what << " hit " << h;
    EXPECT_EQ(a[h].score, b[h].score) << what << " hit " << h;
  }
  if (scored_out != nullptr) *scored_out = scored;
}

void ExpectBoundedEqualsFullScan(const ClipStore& store, const Features& f, size_t views,
                                 size_t dim, const std::string& what) {
  ASSERT_TRUE(store.has_approximate());
  std::mt19937_64 rng(11);
  std::normal_distribution<float> normal(0.0f, 1.0f);
  std::vector<std::vector<float>> queries;
  for (size_t i = 0; i < 3; ++i) {  // random directions
    std::vector<float> q(dim);
    for (float& x : q) x = normal(rng);
    queries.push_back(q);
  }
  for (size_t i : {size_t{0}, f.uids.size() / 2, f.uids.size() - 1}) {  // stored vectors
    queries.push_back(store.TextFeature(i));
    const std::vector<float> img = store.ImageFeatures(i);
    queries.emplace_back(img.begin() + static_cast<ptrdiff_t>((views - 1) * dim), img.end());
    std::vector<float> near = img;  // a stored view plus noise
    near.resize(dim);
    for (float& x : near) x += 0.05f * normal(rng);
    queries.push_back(near);
  }
  for (size_t qi = 0; qi < queries.size(); ++qi) {
    for (size_t k : {size_t{1}, size_t{7}, size_t{50}, f.uids.size() + 5}) {
      for (float thres : {-10.0f, 0.0f, 0.5f, 1.2f, 1.5f, 3.0f}) {
        ExpectSameAsFullScan(store, queries[qi], k, thres, what + " query " + std::to_string(qi));
      }
    }
  }
}

TEST_F(ClipStoreTest, BoundedExactEqualsFullScanOnClusteredFeatures) {
  ExpectBoundedEqualsFullScan(*store_, features_, kViews, kDim, "clustered d=64");
  // In more dimensions than the bound codes hold (residuals matter), clustered.
  const Features f = MakeFeatures(500, 3, 200, 21, 10);
  auto store = ClipStore::Open(WriteStore(dir_.path() / "d200.mlsc", f, 3, 200));
  ExpectBoundedEqualsFullScan(*store, f, 3, 200, "clustered d=200");
  // A query equal to a stored text vector: the bounds prune most assets.
  size_t scored = 0;
  ExpectSameAsFullScan(*store, store->TextFeature(17), 10, -10.0f, "stored text", &scored);
  EXPECT_LT(scored, store->size() / 2);
}

TEST_F(ClipStoreTest, BoundedExactEqualsFullScanOnIsotropicFeatures) {
  // Independent Gaussian vectors in 256 dimensions: no useful low-dimensional structure, the
  // bounds are loose, the answer must still be exact. Also a tiny dimension (tail loops).
  for (const auto& [n, views, dim] : {std::tuple<size_t, size_t, size_t>{400, 3, 256},
                                      std::tuple<size_t, size_t, size_t>{300, 2, 8},
                                      std::tuple<size_t, size_t, size_t>{50, 1, 20}}) {
    std::mt19937_64 rng(5 + dim);
    std::normal_distribution<float> normal(0.0f, 1.0f);
    Features f;
    for (size_t i = 0; i < n; ++i) {
      f.uids.push_back("iso_" + std::to_string(i));
      for (size_t j = 0; j < views * dim; ++j) f.img.push_back(normal(rng));
      for (size_t j = 0; j < dim; ++j) f.text.push_back(normal(rng));
    }
    const std::string name = "iso_" + std::to_string(dim);
    auto store = ClipStore::Open(WriteStore(dir_.path() / (name + ".mlsc"), f, views, dim));
    store->Check();
    ExpectBoundedEqualsFullScan(*store, f, views, dim, name);
  }
}

TEST_F(ClipStoreTest, BoundedExactKeepsTieOrderAndFilters) {
  // 40 groups of 6 assets with identical features (exact score ties), UIDs added out of order.
  std::mt19937_64 rng(3);
  std::normal_distribution<float> normal(0.0f, 1.0f);
  Features f;
  for (size_t g = 0; g < 40; ++g) {
    std::vector<float> img(kViews * kDim), text(kDim);
    for (float& x : img) x = normal(rng);
    for (float& x : text) x = normal(rng);
    for (size_t c = 0; c < 6; ++c) {
      f.uids.push_back("tie_" + std::to_string((c * 37 + g * 11) % 1000) + "_" + std::to_string(g));
      f.img.insert(f.img.end(), img.begin(), img.end());
      f.text.insert(f.text.end(), text.begin(), text.end());
    }
  }
  auto store = ClipStore::Open(WriteStore(dir_.path() / "ties_many.mlsc", f, kViews, kDim));
  ExpectBoundedEqualsFullScan(*store, f, kViews, kDim, "ties");
  const std::vector<float> q = store->TextFeature(9);
  for (size_t k : {1, 2, 3, 5, 6, 7, 13}) {  // cuts inside a tie group
    ExpectSameAsFullScan(*store, q, k, -10.0f, "ties k " + std::to_string(k));
    ExpectSameAsFullScan(*store, q, k, -10.0f, "ties odd rows", nullptr,
                         [](size_t row) { return row % 2 == 1; });
    ExpectSameAsFullScan(*store, q, k, 0.2f, "ties keep none", nullptr,
                         [](size_t) { return false; });
  }
}

TEST_F(ClipStoreTest, KeepFilterAndFromVectorsAgree) {
  const std::vector<float> q = QueryNear(3);
  ClipSearchOptions options;
  options.threshold = -10;
  options.top_k = 30;
  options.keep = [&](size_t row) { return store_->uid(row).back() != '1'; };
  const auto hits = store_->Search(q, options);
  ASSERT_EQ(hits.size(), 30u);
  for (const ClipHit& hit : hits) EXPECT_NE(hit.uid.back(), '1');
  auto memory =
      ClipStore::FromVectors(features_.uids, kViews, kDim, features_.img, features_.text, "mem");
  EXPECT_FALSE(memory->has_approximate());
  const auto same = memory->Search(q, options);
  ASSERT_EQ(same.size(), hits.size());
  for (size_t h = 0; h < hits.size(); ++h) {
    EXPECT_EQ(same[h].uid, hits[h].uid);
    EXPECT_EQ(same[h].score, hits[h].score);
  }
}

TEST_F(ClipStoreTest, BadQueriesAndBadWritesAreErrors) {
  EXPECT_THROW(store_->Search(std::vector<float>(kDim - 1, 1.0f)), Error);
  EXPECT_THROW(store_->Search(std::vector<float>(kDim, 0.0f)), Error);
  std::vector<float> nan(kDim, 1.0f);
  nan[3] = std::nanf("");
  EXPECT_THROW(store_->Search(nan), Error);

  ClipStoreWriter writer(dir_.path() / "bad.mlsc", kViews, kDim);
  const std::vector<float> img(kViews * kDim, 1.0f), text(kDim, 1.0f);
  EXPECT_THROW(writer.Add("x", std::span(img).first(kDim), text), Error);
  EXPECT_THROW(writer.Add("x", img, std::span(text).first(3)), Error);
  std::vector<float> inf = img;
  inf[100] = INFINITY;
  EXPECT_THROW(writer.Add("x", inf, text), Error);
  EXPECT_THROW(writer.Add("x", img, std::vector<float>(kDim, 0.0f)), Error);
  EXPECT_THROW(writer.Add("", img, text), Error);
  writer.Add("x", img, text);
  try {
    writer.Add("x", img, text);
    FAIL() << "duplicate accepted";
  } catch (const Error& e) {
    EXPECT_EQ(e.uid(), "x");
  }
  writer.Finish();
  EXPECT_EQ(ClipStore::Open(dir_.path() / "bad.mlsc")->size(), 1u);
}

TEST_F(ClipStoreTest, AbandonedWriterLeavesNothing) {
  {
    ClipStoreWriter writer(dir_.path() / "sub" / "gone.mlsc", kViews, kDim);
    writer.Add("x", std::vector<float>(kViews * kDim, 1.0f), std::vector<float>(kDim, 1.0f));
  }
  EXPECT_TRUE(fs::is_empty(dir_.path() / "sub"));
}

TEST_F(ClipStoreTest, DamagedFilesAreErrorsNotCrashes) {
  const std::string bytes = ReadFile(path_);
  const fs::path bad = dir_.path() / "damaged.mlsc";
  auto write = [&](const std::string& data) {
    std::ofstream(bad, std::ios::binary | std::ios::trunc) << data;
  };
  // Every truncation length class: empty, inside the header, inside each section.
  for (size_t len : {size_t{0}, size_t{10}, size_t{63}, size_t{64}, size_t{1000}, bytes.size() / 2,
                     bytes.size() - 100, bytes.size() - 1}) {
    write(bytes.substr(0, len));
    EXPECT_THROW(ClipStore::Open(bad), Error) << "length " << len;
  }
  write(bytes + "x");
  EXPECT_THROW(ClipStore::Open(bad), Error);
  // Header fields set to hostile values.
  for (size_t field : {size_t{0}, size_t{8}, size_t{12}, size_t{24}, size_t{28}, size_t{32},
                       size_t{40}, size_t{48}}) {
    for (uint32_t value : {0u, 1u, 0x7fffffffu, 0xffffffffu}) {
      std::string copy = bytes;
      std::memcpy(copy.data() + field, &value, sizeof value);
      if (copy == bytes) continue;
      write(copy);
      try {
        auto store = ClipStore::Open(bad);
        // Accepted only if still consistent: then searching and checking must be safe.
        store->Search(QueryNear(1));
        store->Check();
        ADD_FAILURE() << "field " << field << " = " << value << " accepted";
      } catch (const Error& e) {
        EXPECT_NE(std::string(e.what()).find("damaged.mlsc"), std::string::npos) << e.what();
      }
    }
  }
  // A UID entry pointing outside the strings.
  {
    std::string copy = bytes;
    uint64_t uids_off;
    std::memcpy(&uids_off, copy.data() + 40, 8);
    const uint32_t huge = 0xfffffff0u;
    std::memcpy(copy.data() + uids_off, &huge, 4);
    write(copy);
    EXPECT_THROW(ClipStore::Open(bad), Error);
  }
  // A flipped vector byte: opens (no full read on open) but Check finds it.
  {
    std::string copy = bytes;
    copy[5000] = static_cast<char>(copy[5000] ^ 0x40);
    write(copy);
    auto store = ClipStore::Open(bad);
    EXPECT_THROW(store->Check(), Error);
  }
  EXPECT_THROW(ClipStore::Open(dir_.path() / "missing.mlsc"), Error);
}

}  // namespace
}  // namespace mlspaces
