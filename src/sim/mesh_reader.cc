#include "mesh_reader.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <unordered_map>

#include "mlspaces/core/error.h"

// The float arithmetic below must round as tinyobjloader's does in Debian's libmujoco (built
// for baseline x86-64, no FMA): never fuse a multiply and an add, whatever -march says.
#if defined(__clang__)
#pragma clang fp contract(off)
#elif defined(__GNUC__)
#pragma GCC optimize("fp-contract=off")
#endif

namespace mlspaces::sim {
namespace {

bool IsSpace(char c) { return c == ' ' || c == '\t'; }
bool IsDigit(char c) { return static_cast<unsigned>(c - '0') < 10u; }

// tinyobjloader's number grammar and arithmetic (digit by digit into a double, fraction digits
// scaled by 10^-k, exponent applied as ldexp(m * 5^e, e)), so floats equal MuJoCo's. Unlike
// tinyobjloader, which reads a bad number as 0, a token that is not entirely a number fails.
bool ParseObjReal(const char* s, const char* end, double* out) {
  if (s >= end) return false;
  double mantissa = 0;
  int exponent = 0;
  char sign = '+';
  const char* p = s;
  if (*p == '+' || *p == '-') sign = *p++;
  int digits = 0;
  while (p < end && IsDigit(*p)) {
    mantissa = mantissa * 10 + static_cast<int>(*p - '0');
    ++p;
    ++digits;
  }
  if (p < end && *p == '.') {
    ++p;
    static const double kPow[] = {1.0, 0.1, 0.01, 0.001, 0.0001, 0.00001, 0.000001, 0.0000001};
    int read = 1;
    while (p < end && IsDigit(*p)) {
      mantissa += static_cast<int>(*p - '0') * (read < 8 ? kPow[read] : std::pow(10.0, -read));
      ++read;
      ++p;
      ++digits;
    }
  }
  if (digits == 0) return false;
  if (p < end && (*p == 'e' || *p == 'E')) {
    ++p;
    char exp_sign = '+';
    if (p < end && (*p == '+' || *p == '-')) exp_sign = *p++;
    int read = 0;
    while (p < end && IsDigit(*p)) {
      if (exponent > std::numeric_limits<int>::max() / 10) return false;
      exponent = exponent * 10 + (*p - '0');
      ++p;
      ++read;
    }
    if (read == 0) return false;
    if (exp_sign == '-') exponent = -exponent;
  }
  if (p != end) return false;
  *out = (sign == '+' ? 1 : -1) *
         (exponent ? std::ldexp(mantissa * std::pow(5.0, exponent), exponent) : mantissa);
  return true;
}

bool ParseInt(const char* s, const char* end, long* out) {
  if (s >= end) return false;
  bool neg = false;
  if (*s == '+' || *s == '-') neg = *s++ == '-';
  if (s >= end) return false;
  long v = 0;
  for (; s < end; ++s) {
    if (!IsDigit(*s) || v > 100000000000L) return false;
    v = v * 10 + (*s - '0');
  }
  *out = neg ? -v : v;
  return true;
}

// pnpoly point-in-triangle test in float, as tinyobjloader does it.
bool InTriangle(const float* x, const float* y, float tx, float ty) {
  bool c = false;
  for (int i = 0, j = 2; i < 3; j = i++) {
    if (((y[i] > ty) != (y[j] > ty)) && (tx < (x[j] - x[i]) * (ty - y[i]) / (y[j] - y[i]) + x[i])) {
      c = !c;
    }
  }
  return c;
}

// Ear clipping of a polygon of n > 3 corners (indices into v) as the tinyobjloader MuJoCo
// 2.2.2 is built with does it, in float arithmetic: project on the two axes picked at the
// first non-degenerate corner, take the polygon's signed area there, clip ears whose turn
// agrees with it and that hold no other corner. Appends the triangles to `t`; like
// tinyobjloader, a polygon that cannot be reduced to one last triangle loses the rest.
void EarClip(const std::vector<float>& v, const int* poly, size_t n, std::vector<int>* t) {
  int axes[2] = {1, 2};
  for (size_t k = 0; k < n; ++k) {
    const float* p0 = &v[3 * poly[k]];
    const float* p1 = &v[3 * poly[(k + 1) % n]];
    const float* p2 = &v[3 * poly[(k + 2) % n]];
    float e0x = p1[0] - p0[0], e0y = p1[1] - p0[1], e0z = p1[2] - p0[2];
    float e1x = p2[0] - p1[0], e1y = p2[1] - p1[1], e1z = p2[2] - p1[2];
    float cx = std::fabs(e0y * e1z - e0z * e1y);
    float cy = std::fabs(e0z * e1x - e0x * e1z);
    float cz = std::fabs(e0x * e1y - e0y * e1x);
    const float eps = std::numeric_limits<float>::epsilon();
    if (cx > eps || cy > eps || cz > eps) {
      if (!(cx > cy && cx > cz)) {
        axes[0] = 0;
        if (cz > cx && cz > cy) axes[1] = 1;
      }
      break;
    }
  }
  float area = 0;
  for (size_t k = 0; k < n; ++k) {
    const float* a = &v[3 * poly[k]];
    const float* b = &v[3 * poly[(k + 1) % n]];
    area += (a[axes[0]] * b[axes[1]] - a[axes[1]] * b[axes[0]]) * 0.5f;
  }
  std::vector<int> rem(poly, poly + n);
  size_t guess = 0;
  size_t iterations = rem.size();
  size_t previous = rem.size();
  while (rem.size() > 3 && iterations > 0) {
    const size_t m = rem.size();
    if (guess >= m) guess -= m;
    if (previous != m) {
      previous = m;
      iterations = m;
    } else {
      --iterations;
    }
    int ind[3];
    float x[3], y[3];
    for (int k = 0; k < 3; ++k) {
      ind[k] = rem[(guess + k) % m];
      x[k] = v[3 * ind[k] + axes[0]];
      y[k] = v[3 * ind[k] + axes[1]];
    }
    float cross = (x[1] - x[0]) * (y[2] - y[1]) - (y[1] - y[0]) * (x[2] - x[1]);
    if (cross * area < 0.0f) {
      ++guess;
      continue;
    }
    bool overlap = false;
    for (size_t other = 3; other < m && !overlap; ++other) {
      int o = rem[(guess + other) % m];
      overlap = InTriangle(x, y, v[3 * o + axes[0]], v[3 * o + axes[1]]);
    }
    if (overlap) {
      ++guess;
      continue;
    }
    t->insert(t->end(), ind, ind + 3);
    rem.erase(rem.begin() + static_cast<long>((guess + 1) % m));
  }
  if (rem.size() == 3) t->insert(t->end(), rem.begin(), rem.end());
}

// True when some directed edge a->b appears twice among the triangles `t` over `nv` vertices
// (MuJoCo 2.2.2: "faces have inconsistent orientation"). Linear: edges bucketed by start.
bool HasRepeatedDirectedEdge(const std::vector<int>& t, int nv) {
  std::vector<int> start(nv + 1, 0);
  for (int a : t) ++start[a + 1];
  for (int i = 0; i < nv; ++i) start[i + 1] += start[i];
  std::vector<int> fill(start.begin(), start.end() - 1);
  std::vector<int> to(t.size());
  for (size_t i = 0; i < t.size(); i += 3) {
    for (int k = 0; k < 3; ++k) to[fill[t[i + k]]++] = t[i + (k + 1) % 3];
  }
  for (int a = 0; a < nv; ++a) {
    int* b = to.data() + start[a];
    int n = start[a + 1] - start[a];
    if (n > 16) {
      std::sort(b, b + n);
      if (std::adjacent_find(b, b + n) != b + n) return true;
      continue;
    }
    for (int i = 1; i < n; ++i) {
      for (int j = 0; j < i; ++j) {
        if (b[i] == b[j]) return true;
      }
    }
  }
  return false;
}

}  // namespace

bool ReadObjMesh(std::string_view text, const std::string& path, TriMesh* out) {
  auto fail = [&](int line, const std::string& message) -> Error {
    return Error(message, path, "line " + std::to_string(line));
  };
  std::vector<float> v;      // every OBJ vertex, 3 floats each
  std::vector<int> corners;  // resolved 0-based indices, face after face
  std::vector<int> sides;    // corners per face
  bool any_face = false;
  v.reserve(text.size() / 24);
  corners.reserve(text.size() / 8);
  long max_index = -1;  // largest positive index and its line: forward references are allowed
  int max_index_line = 0;
  // Set when MuJoCo should read the file itself; the whole file is still checked first, so a
  // malformed file is reported by us rather than handed to MuJoCo's loader.
  bool decline = false;
  int line_no = 0;
  const char* p = text.data();
  const char* const end = p + text.size();
  std::vector<const char*> tok, tok_end;
  while (p < end) {
    ++line_no;
    const char* eol = static_cast<const char*>(std::memchr(p, '\n', end - p));
    if (!eol) eol = end;
    const char* q = p;
    const char* e = eol;
    p = eol + 1;
    while (e > q && (e[-1] == '\r' || IsSpace(e[-1]))) --e;
    while (q < e && IsSpace(*q)) ++q;
    if (q == e || *q == '#') continue;
    const char* kw = q;
    while (q < e && !IsSpace(*q)) ++q;
    std::string_view key(kw, q - kw);
    tok.clear();
    tok_end.clear();
    while (q < e) {
      while (q < e && IsSpace(*q)) ++q;
      if (q == e) break;
      tok.push_back(q);
      while (q < e && !IsSpace(*q)) ++q;
      tok_end.push_back(q);
    }
    const int n = static_cast<int>(tok.size());
    if (key == "v") {
      if (n < 3) throw fail(line_no, "vertex needs 3 coordinates, found " + std::to_string(n));
      for (int k = 0; k < 3; ++k) {
        double x;
        if (!ParseObjReal(tok[k], tok_end[k], &x)) {
          throw fail(line_no, "bad vertex coordinate '" + std::string(tok[k], tok_end[k]) + "'");
        }
        v.push_back(static_cast<float>(x));
      }
    } else if (key == "f") {
      // Faces of fewer than three corners (tinyobjloader drops them): MuJoCo's business.
      const bool keep = n >= 3;
      decline |= !keep;
      const long nv = static_cast<long>(v.size() / 3);
      for (int k = 0; k < n; ++k) {
        const char* slash = static_cast<const char*>(std::memchr(tok[k], '/', tok_end[k] - tok[k]));
        const char* ve = slash ? slash : tok_end[k];
        long idx;
        if (!ParseInt(tok[k], ve, &idx) || idx == 0) {
          throw fail(line_no, "bad face vertex index '" + std::string(tok[k], tok_end[k]) + "'");
        }
        if (idx < 0) {
          idx += nv;
          if (idx < 0) {
            throw fail(line_no, "relative face index " + std::string(tok[k], ve) +
                                    " before the first vertex (" + std::to_string(nv) + " so far)");
          }
        } else {
          idx -= 1;
          if (idx > max_index) {
            max_index = idx;
            max_index_line = line_no;
          }
        }
        if (idx > std::numeric_limits<int>::max() / 2) {
          throw fail(line_no, "face vertex index " + std::string(tok[k], ve) + " too large");
        }
        if (keep) corners.push_back(static_cast<int>(idx));
      }
      if (keep) sides.push_back(n);
      any_face = true;
    } else if (key == "o" || key == "g" || key == "usemtl") {
      decline |= any_face;  // MuJoCo 2.2.2 keeps the first shape only
    } else if (key == "l" || key == "p") {
      decline = true;
    }
  }
  const long nv = static_cast<long>(v.size() / 3);
  if (max_index >= nv) {
    throw fail(max_index_line, "face vertex index " + std::to_string(max_index + 1) +
                                   " out of range (the file has " + std::to_string(nv) +
                                   " vertices)");
  }
  if (decline || !any_face) return false;

  // Triangles in file order, polygons clipped as tinyobjloader does.
  std::vector<int> t;
  t.reserve(corners.size() + corners.size() / 2);
  const int* c = corners.data();
  for (int n : sides) {
    if (n == 3) {
      t.insert(t.end(), c, c + 3);
    } else {
      EarClip(v, c, n, &t);
    }
    c += n;
  }

  // MuJoCo rejects meshes with a directed edge used twice; let it say so itself.
  if (HasRepeatedDirectedEdge(t, static_cast<int>(nv))) return false;

  // Keep only used vertices, in first-use order.
  std::vector<int> remap(nv, -1);
  out->vert.clear();
  out->face.clear();
  out->vert.reserve(3 * nv);
  out->face.reserve(t.size());
  int used = 0;
  for (int i : t) {
    if (remap[i] < 0) {
      remap[i] = used++;
      out->vert.insert(out->vert.end(), &v[3 * i], &v[3 * i] + 3);
    }
    out->face.push_back(remap[i]);
  }
  return used >= 4;
}

bool ReadStlMesh(std::string_view data, TriMesh* out) {
  if (data.size() < 84) return false;
  uint32_t nface;
  std::memcpy(&nface, data.data() + 80, 4);
  if (nface < 1 || nface > 200000 || 84 + 50ull * nface != data.size()) return false;
  struct Key {
    uint32_t b[3];
    bool operator==(const Key& o) const {
      return b[0] == o.b[0] && b[1] == o.b[1] && b[2] == o.b[2];
    }
  };
  struct Hash {
    size_t operator()(const Key& k) const {
      uint64_t h = k.b[0] * 0x9E3779B97F4A7C15ull;
      h ^= (h >> 29) + k.b[1] * 0xBF58476D1CE4E5B9ull;
      h ^= (h >> 31) + k.b[2] * 0x94D049BB133111EBull;
      return static_cast<size_t>(h ^ (h >> 32));
    }
  };
  std::unordered_map<Key, int, Hash> ids;
  ids.reserve(nface * 2);
  out->vert.clear();
  out->face.clear();
  out->face.reserve(3 * nface);
  for (uint32_t i = 0; i < nface; ++i) {
    for (int j = 0; j < 3; ++j) {
      const char* src = data.data() + 84 + 50 * i + 12 * (j + 1);
      float f[3];
      Key key;
      std::memcpy(f, src, 12);
      std::memcpy(key.b, src, 12);
      for (float x : f) {
        if (!std::isfinite(x) || std::fabs(x) > 1073741824.0) return false;  // MuJoCo: 2^30
      }
      // MuJoCo merges equal corners (== on floats): +0 and -0 are one vertex there.
      for (int k = 0; k < 3; ++k) {
        if (f[k] == 0) key.b[k] = 0;
      }
      auto [it, fresh] = ids.try_emplace(key, static_cast<int>(ids.size()));
      if (fresh) out->vert.insert(out->vert.end(), f, f + 3);
      out->face.push_back(it->second);
    }
  }
  return out->vert.size() >= 12;
}

std::string EncodeMsh(const TriMesh& mesh) {
  const size_t nv = mesh.vert.size() / 3;
  // Placeholder normals (+z; MuJoCo normalizes them) so MuJoCo skips computing vertex normals,
  // which only rendering uses.
  int32_t header[4] = {static_cast<int32_t>(nv), static_cast<int32_t>(nv), 0,
                       static_cast<int32_t>(mesh.face.size() / 3)};
  std::string out(sizeof header + (6 * nv + mesh.face.size()) * 4, '\0');
  char* p = out.data();
  std::memcpy(p, header, sizeof header);
  p += sizeof header;
  std::memcpy(p, mesh.vert.data(), mesh.vert.size() * 4);
  p += mesh.vert.size() * 4;
  const float up[3] = {0, 0, 1};
  for (size_t i = 0; i < nv; ++i, p += sizeof up) std::memcpy(p, up, sizeof up);
  std::memcpy(p, mesh.face.data(), mesh.face.size() * 4);
  return out;
}

}  // namespace mlspaces::sim
