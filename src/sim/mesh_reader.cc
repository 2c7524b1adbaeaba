#include "mesh_reader.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <unordered_map>

#include "mlspaces/core/error.h"

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

struct Corner {
  long index;  // 0-based OBJ vertex index once resolved
  int line;
};

}  // namespace

bool ReadObjMesh(std::string_view text, const std::string& path, TriMesh* out) {
  auto fail = [&](int line, const std::string& message) -> Error {
    return Error(message, path, "line " + std::to_string(line));
  };
  std::vector<float> v;       // every OBJ vertex, 3 floats each
  std::vector<Corner> tris;   // 3 corners per triangle (quads split later)
  std::vector<Corner> quads;  // 4 corners per quad
  std::vector<int> order;     // per polygon: >= 0 triangle start in tris, < 0: ~quad start
  bool any_face = false;
  int line_no = 0;
  const char* p = text.data();
  const char* const end = p + text.size();
  const char* tok[64];
  const char* tok_end[64];
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
    int n = 0;
    while (q < e) {
      while (q < e && IsSpace(*q)) ++q;
      if (q == e) break;
      if (n == 64) return false;  // a very large polygon: MuJoCo's business
      tok[n] = q;
      while (q < e && !IsSpace(*q)) ++q;
      tok_end[n++] = q;
    }
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
      if (n < 3 || n > 4) return false;  // degenerate faces and polygons: MuJoCo's business
      any_face = true;
      Corner c[4];
      for (int k = 0; k < n; ++k) {
        const char* slash = static_cast<const char*>(std::memchr(tok[k], '/', tok_end[k] - tok[k]));
        const char* ve = slash ? slash : tok_end[k];
        long idx;
        if (!ParseInt(tok[k], ve, &idx) || idx == 0) {
          throw fail(line_no, "bad face vertex index '" + std::string(tok[k], tok_end[k]) + "'");
        }
        long nv = static_cast<long>(v.size() / 3);
        if (idx < 0) {
          idx += nv;
          if (idx < 0) {
            throw fail(line_no, "relative face index " + std::string(tok[k], ve) + " before " +
                                    "the first vertex (" + std::to_string(nv) + " so far)");
          }
        } else {
          idx -= 1;
        }
        c[k] = {idx, line_no};
      }
      if (n == 3) {
        order.push_back(static_cast<int>(tris.size()));
        tris.insert(tris.end(), c, c + 3);
      } else {
        order.push_back(~static_cast<int>(quads.size()));
        quads.insert(quads.end(), c, c + 4);
      }
    } else if (key == "o" || key == "g" || key == "usemtl") {
      if (any_face) return false;  // MuJoCo 2.2.2 keeps the first shape only
    } else if (key == "l" || key == "p") {
      return false;
    }
  }
  if (!any_face) return false;
  const long nv = static_cast<long>(v.size() / 3);
  auto check = [&](const Corner& c) {
    if (c.index >= nv) {
      throw fail(c.line, "face vertex index " + std::to_string(c.index + 1) +
                             " out of range (the file has " + std::to_string(nv) +
                             " vertices)");
    }
  };
  for (const Corner& c : tris) check(c);
  for (const Corner& c : quads) check(c);

  // Triangles in file order; quads split as tinyobjloader does (float arithmetic).
  std::vector<long> t;
  t.reserve(3 * (tris.size() / 3 + 2 * quads.size() / 4));
  for (int o : order) {
    if (o >= 0) {
      for (int k = 0; k < 3; ++k) t.push_back(tris[o + k].index);
      continue;
    }
    const Corner* c = &quads[~o];
    const float* a = &v[3 * c[0].index];
    const float* b = &v[3 * c[1].index];
    const float* d = &v[3 * c[2].index];
    const float* f = &v[3 * c[3].index];
    float e02[3], e13[3];
    for (int k = 0; k < 3; ++k) {
      e02[k] = d[k] - a[k];
      e13[k] = f[k] - b[k];
    }
    float sqr02 = e02[0] * e02[0] + e02[1] * e02[1] + e02[2] * e02[2];
    float sqr13 = e13[0] * e13[0] + e13[1] * e13[1] + e13[2] * e13[2];
    const int split[2][6] = {{0, 1, 2, 0, 2, 3}, {0, 1, 3, 1, 2, 3}};
    for (int k : split[sqr02 < sqr13 ? 0 : 1]) t.push_back(c[k].index);
  }

  // MuJoCo rejects meshes with a directed edge used twice; let it say so itself.
  std::vector<uint64_t> edges;
  edges.reserve(t.size());
  for (size_t i = 0; i < t.size(); i += 3) {
    for (int k = 0; k < 3; ++k) {
      edges.push_back(static_cast<uint64_t>(t[i + k]) << 32 |
                      static_cast<uint64_t>(t[i + (k + 1) % 3]));
    }
  }
  std::sort(edges.begin(), edges.end());
  if (std::adjacent_find(edges.begin(), edges.end()) != edges.end()) return false;

  // Keep only used vertices, in first-use order.
  std::vector<int> remap(nv, -1);
  out->vert.clear();
  out->face.clear();
  out->face.reserve(t.size());
  int used = 0;
  for (long i : t) {
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
        if (!std::isfinite(x) || std::fabs(x) > std::pow(2.0, 30)) return false;
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
