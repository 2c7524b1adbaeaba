// The physics-only compile of compute-metadata (ComputeAssetFacts(xml, true): no textures,
// materials or lights, no collisions so no convex hulls) must give the very same facts as a
// full MuJoCo 3.5 compile of the asset, bit for bit, over generated meshes (OBJ in its
// variants, binary STL, polygons) and MJCF mass features; bad mesh files give one-line errors
// naming the asset file.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "mlspaces/core/error.h"
#include "mlspaces/core/files.h"
#include "mlspaces/sim/asset_facts.h"
#include "mlspaces/sim/mujoco_handlers.h"

namespace mlspaces::sim {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;
using ::testing::Not;

struct BlobOptions {
  int rings = 14;
  int segs = 21;
  bool quads = false;     // middle bands as quads (tinyobjloader's ear clipping splits them)
  bool vt_vn = false;     // vt/vn lines and f v/vt/vn corners
  bool vn_only = false;   // f v//vn corners
  bool negative = false;  // relative (negative) face indices
  bool crlf = false;      // CRLF line ends, comments, o/g/usemtl/s before the faces
  bool unused = false;    // vertices no face uses
  double offset[3] = {0.3, -0.2, 0.15};
  unsigned seed = 1;
};

// A non-convex, off-centre blob: a UV sphere with jittered radius and a deep dent.
std::string BlobObj(const BlobOptions& o) {
  std::mt19937 rng(o.seed);
  std::uniform_real_distribution<double> jitter(-0.08, 0.08);
  std::string s;
  const char* nl = o.crlf ? "\r\n" : "\n";
  char buf[160];
  if (o.crlf) s += std::string("# generated") + nl + "mtllib none.mtl" + nl + "o blob" + nl;
  if (o.unused) s += std::string("v 9 9 9") + nl;
  int base = o.unused ? 1 : 0;
  auto vert = [&](double th, double ph) {
    double r = 0.05 * (1 + jitter(rng));
    if (th > 1.0 && th < 2.0 && ph > 1.0 && ph < 2.2) r *= 0.45;  // the dent
    std::snprintf(
        buf, sizeof buf, "v %.7f %.7f %.7f%s", o.offset[0] + r * std::sin(th) * std::cos(ph),
        o.offset[1] + r * std::sin(th) * std::sin(ph), o.offset[2] + 0.7 * r * std::cos(th), nl);
    s += buf;
  };
  vert(0, 0);
  for (int i = 1; i < o.rings; ++i) {
    for (int j = 0; j < o.segs; ++j) vert(M_PI * i / o.rings, 2 * M_PI * j / o.segs);
  }
  vert(M_PI, 0);
  if (o.unused) s += std::string("v -9 -9 -9") + nl;
  const int n = 2 + (o.rings - 1) * o.segs;
  const int total = n + (o.unused ? 2 : 0);
  if (o.vt_vn || o.vn_only) {
    for (int k = 0; k < n; ++k) {
      if (o.vt_vn) {
        std::snprintf(buf, sizeof buf, "vt %.4f %.4f%s", (k % 7) / 7.0, (k % 5) / 5.0, nl);
        s += buf;
      }
      std::snprintf(buf, sizeof buf, "vn 0 0 1%s", nl);
      s += buf;
    }
  }
  if (o.crlf) s += std::string("g part") + nl + "usemtl skin" + nl + "s 1" + nl;
  auto id = [&](int ring, int seg) { return 2 + (ring - 1) * o.segs + (seg % o.segs); };
  auto corner = [&](int k) {
    int idx = base + k;                            // 1-based index among all v lines
    int ref = o.negative ? idx - total - 1 : idx;  // all v lines come before the faces
    std::string c = std::to_string(ref);
    if (o.vt_vn) c += "/" + std::to_string(k) + "/" + std::to_string(k);
    if (o.vn_only) c += "//" + std::to_string(k);
    return c;
  };
  auto face = [&](std::initializer_list<int> ks) {
    s += "f";
    for (int k : ks) s += " " + corner(k);
    s += nl;
  };
  for (int j = 0; j < o.segs; ++j) face({1, id(1, j), id(1, j + 1)});
  for (int i = 1; i < o.rings - 1; ++i) {
    for (int j = 0; j < o.segs; ++j) {
      if (o.quads) {
        face({id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1)});
      } else {
        face({id(i, j), id(i + 1, j), id(i + 1, j + 1)});
        face({id(i, j), id(i + 1, j + 1), id(i, j + 1)});
      }
    }
  }
  for (int j = 0; j < o.segs; ++j) face({n, id(o.rings - 1, j + 1), id(o.rings - 1, j)});
  return s;
}

// Binary STL of the triangles of an OBJ made by BlobObj (triangles only, plain indices).
std::string StlFromObj(const std::string& obj) {
  std::vector<float> v;
  std::vector<int> f;
  std::istringstream in(obj);
  for (std::string line; std::getline(in, line);) {
    std::istringstream l(line);
    std::string k;
    l >> k;
    if (k == "v") {
      float x, y, z;
      l >> x >> y >> z;
      v.insert(v.end(), {x, y, z});
    } else if (k == "f") {
      for (int a; l >> a;) f.push_back(a - 1);
    }
  }
  std::string out(80, ' ');
  uint32_t n = static_cast<uint32_t>(f.size() / 3);
  out.append(reinterpret_cast<const char*>(&n), 4);
  for (uint32_t t = 0; t < n; ++t) {
    float rec[12] = {0, 0, 0};
    for (int c = 0; c < 3; ++c) std::memcpy(rec + 3 + 3 * c, &v[3 * f[3 * t + c]], 12);
    out.append(reinterpret_cast<const char*>(rec), 48);
    out.append(2, '\0');
  }
  return out;
}

class PhysicsOnly : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::path(::testing::TempDir()) /
           ("mlspaces_mesh_" +
            std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  fs::path Write(const std::string& name, const std::string& data) {
    WriteFileAtomic(dir_ / name, data);
    return dir_ / name;
  }

  // An asset XML: `assets` inside <asset>, `body` inside the one body.
  fs::path Asset(const std::string& assets, const std::string& body, const std::string& top = "") {
    return Write("asset.xml", "<mujoco model=\"m\">" + top + "<asset>" + assets +
                                  "</asset><worldbody><body name=\"b\" pos=\"0.1 0.2 0.3\" "
                                  "quat=\"0.9 0.1 0.3 -0.2\"><freejoint/>" +
                                  body + "</body></worldbody></mujoco>");
  }

  // Fast (physics-only) facts equal a full compile's.
  void ExpectSame(const fs::path& xml, const std::string& what) {
    AssetFacts fast = ComputeAssetFacts(xml, true);
    AssetFacts full = ComputeAssetFacts(xml, false);
    EXPECT_GT(full.mass, 0) << what;
    // Bitwise: MuJoCo compiles the same meshes either way.
    EXPECT_EQ(fast.mass, full.mass) << what;
    // And MuJoCo's own compile of the asset file, with no composer in between.
    char error[1000] = "";
    ModelPtr own(mj_loadXML(xml.c_str(), nullptr, error, sizeof error));
    ASSERT_TRUE(own) << what << ": " << error;
    EXPECT_EQ(fast.mass, own->body_mass[1]) << what;
    EXPECT_EQ(fast.aabb_min, full.aabb_min) << what;
    EXPECT_EQ(fast.aabb_max, full.aabb_max) << what;
    EXPECT_EQ(fast.bounding_box, full.bounding_box) << what;
  }

  fs::path dir_;
};

TEST_F(PhysicsOnly, ObjVariantsEqualFullCompile) {
  std::vector<std::pair<std::string, BlobOptions>> cases;
  BlobOptions o;
  cases.push_back({"triangles", o});
  o.quads = true;
  cases.push_back({"quads", o});
  o.vt_vn = true;
  o.seed = 2;
  cases.push_back({"quads+vt+vn", o});
  o = {};
  o.vn_only = true;
  o.negative = true;
  o.seed = 3;
  cases.push_back({"negative+vn", o});
  o = {};
  o.crlf = true;
  o.unused = true;
  o.quads = true;
  o.seed = 4;
  cases.push_back({"crlf+header+unused", o});
  for (unsigned seed = 10; seed < 16; ++seed) {
    o = {};
    o.seed = seed;
    o.rings = 5 + seed;
    o.segs = 3 + 2 * seed;
    o.quads = seed % 2;
    o.offset[0] = -0.5 + 0.1 * seed;
    cases.push_back({"seed " + std::to_string(seed), o});
  }
  for (const auto& [what, opts] : cases) {
    fs::path obj = Write("blob.obj", BlobObj(opts));
    ExpectSame(
        Asset("<mesh name=\"blob\" file=\"blob.obj\"/>", "<geom type=\"mesh\" mesh=\"blob\"/>"),
        what);
  }
}

TEST_F(PhysicsOnly, MeshAttributesAndMassFeatures) {
  BlobOptions o;
  o.vt_vn = true;
  Write("blob.obj", BlobObj(o));
  const std::string mesh = "<mesh name=\"blob\" file=\"blob.obj\"";
  const std::string geom = "<geom type=\"mesh\" mesh=\"blob\"";
  struct Case {
    const char* what;
    std::string assets, body, top;
  };
  std::vector<Case> cases = {
      {"unnamed mesh", "<mesh file=\"blob.obj\"/>", "<geom type=\"mesh\" mesh=\"blob\"/>", ""},
      {"scale", mesh + " scale=\"2 0.5 1.5\"/>", geom + "/>", ""},
      {"left-handed scale", mesh + " scale=\"-1 1 1\"/>", geom + "/>", ""},
      {"refpos refquat", mesh + " refpos=\"0.3 -0.2 0.1\" refquat=\"0.8 0.2 0.1 0.3\"/>",
       geom + "/>", ""},
      {"geom pose density", mesh + "/>",
       geom + " pos=\"0.1 0 -0.2\" euler=\"0.3 0.2 0.1\" density=\"650\"/>", ""},
      {"geom mass + box", mesh + "/>",
       geom + " mass=\"2.5\"/><geom type=\"box\" size=\"0.02 0.03 0.04\" pos=\"0.2 0 0\"/>", ""},
      {"explicit inertial", mesh + "/>",
       "<inertial pos=\"0 0 0\" mass=\"3\" diaginertia=\"0.1 0.1 0.1\"/>" + geom + "/>", ""},
      {"default class scale", "<mesh name=\"blob\" class=\"big\" file=\"blob.obj\"/>", geom + "/>",
       "<default><default class=\"big\"><mesh scale=\"3 3 3\"/></default></default>"},
      {"settotalmass", mesh + "/>", geom + "/>", "<compiler settotalmass=\"7\"/>"},
      {"inertiagrouprange", mesh + "/>",
       geom + " group=\"4\"/><geom type=\"sphere\" size=\"0.05\" group=\"1\"/>",
       "<compiler inertiagrouprange=\"0 2\"/>"},
      {"textured material",
       mesh + "/><texture name=\"t\" type=\"2d\" builtin=\"checker\" width=\"64\" height=\"64\"/>"
              "<material name=\"mat\" texture=\"t\"/>",
       geom + " material=\"mat\"/>", ""},
      {"two meshes", mesh + "/><mesh name=\"copy\" file=\"blob.obj\" scale=\"0.5 0.5 0.5\"/>",
       geom + "/><geom type=\"mesh\" mesh=\"copy\" pos=\"0.3 0 0\"/>", ""},
      {"box fitted to mesh", mesh + "/>", "<geom type=\"box\" mesh=\"blob\"/>", ""},
      // The hull-based and other inertias: with collisions off MuJoCo still builds the hull
      // where the inertia needs it.
      {"convex inertia", mesh + " inertia=\"convex\"/>", geom + "/>", ""},
      {"shell inertia", mesh + " inertia=\"shell\"/>", geom + "/>", ""},
      {"maxhullvert", mesh + " maxhullvert=\"12\" inertia=\"convex\"/>", geom + "/>", ""},
  };
  for (const Case& c : cases) ExpectSame(Asset(c.assets, c.body, c.top), c.what);
}

TEST_F(PhysicsOnly, BinaryStlEqualsFullCompile) {
  BlobOptions o;
  o.offset[2] = -0.4;
  std::string stl = StlFromObj(BlobObj(o));
  Write("blob.stl", stl);
  ExpectSame(Asset("<mesh name=\"s\" file=\"blob.stl\" scale=\"1 2 -1\"/>",
                   "<geom type=\"mesh\" mesh=\"s\"/>"),
             "stl");
}

TEST_F(PhysicsOnly, AsciiStlIsRejectedLikeMuJoCo) {
  // MuJoCo reads binary STL only.
  std::string ascii =
      "solid t\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 0 1 0\n"
      "endloop\nendfacet\nendsolid t\n";
  Write("a.stl", ascii);
  fs::path xml = Asset("<mesh name=\"s\" file=\"a.stl\"/>", "<geom type=\"mesh\" mesh=\"s\"/>");
  for (bool fast : {true, false}) {
    try {
      ComputeAssetFacts(xml, fast);
      ADD_FAILURE() << "ASCII STL accepted";
    } catch (const Error& e) {
      EXPECT_THAT(e.what(), HasSubstr("ASCII")) << fast;
    }
  }
}

// A tilted prism over a random star-shaped (non-convex) polygon: one n-gon per cap, quads
// around, so ear clipping meets reflex corners and every projection axis.
std::string StarPrismObj(int n, unsigned seed, const double axis[3]) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> radius(0.02, 0.09);
  double a[3] = {axis[0], axis[1], axis[2]};
  double len = std::sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]);
  for (double& x : a) x /= len;
  // Two unit vectors orthogonal to the axis.
  double u[3] = {1, 0, 0};
  if (std::fabs(a[0]) > 0.9) u[0] = 0, u[1] = 1;
  double d = u[0] * a[0] + u[1] * a[1] + u[2] * a[2];
  for (int i = 0; i < 3; ++i) u[i] -= d * a[i];
  len = std::sqrt(u[0] * u[0] + u[1] * u[1] + u[2] * u[2]);
  for (double& x : u) x /= len;
  double w[3] = {a[1] * u[2] - a[2] * u[1], a[2] * u[0] - a[0] * u[2], a[0] * u[1] - a[1] * u[0]};
  std::string s;
  char buf[160];
  for (double h : {-0.04, 0.05}) {
    for (int k = 0; k < n; ++k) {
      double r = (k % 2 ? 0.4 : 1.0) * radius(rng), t = 2 * M_PI * k / n;
      double p[3];
      for (int i = 0; i < 3; ++i) {
        p[i] = 0.2 + h * a[i] + r * (std::cos(t) * u[i] + std::sin(t) * w[i]);
      }
      std::snprintf(buf, sizeof buf, "v %.7f %.7f %.7f\n", p[0], p[1], p[2]);
      s += buf;
    }
  }
  s += "f";
  for (int k = n; k >= 1; --k) s += " " + std::to_string(k);  // bottom, facing -axis
  s += "\nf";
  for (int k = 1; k <= n; ++k) s += " " + std::to_string(n + k);
  s += "\n";
  for (int k = 1; k <= n; ++k) {
    int k2 = k % n + 1;
    s += "f " + std::to_string(k) + " " + std::to_string(k2) + " " + std::to_string(n + k2) + " " +
         std::to_string(n + k) + "\n";
  }
  return s;
}

TEST_F(PhysicsOnly, PolygonsEqualFullCompile) {
  const double axes[][3] = {{0, 0, 1}, {1, 0, 0}, {0, 1, 0}, {0.3, -0.5, 0.8}, {0.9, 0.4, 0.1}};
  int k = 0;
  for (int n : {5, 6, 8, 11, 16}) {
    for (const auto& axis : axes) {
      const std::string what = std::to_string(n) + "-gon prism " + std::to_string(k);
      fs::path obj = Write("prism.obj", StarPrismObj(n, 100 + k++, axis));
      ExpectSame(Asset("<mesh name=\"p\" file=\"prism.obj\"/>", "<geom type=\"mesh\" mesh=\"p\"/>"),
                 what);
    }
  }
  std::string pent =
      "v 0 0 0\nv 1 0 0\nv 1.3 0.8 0\nv 0.5 1.3 0\nv -0.3 0.8 0\nv 0.5 0.6 0.9\n"
      "f 5 4 3 2 1\nf 1 2 6\nf 2 3 6\nf 3 4 6\nf 4 5 6\nf 5 1 6\n";
  Write("pent.obj", pent);
  ExpectSame(Asset("<mesh name=\"p\" file=\"pent.obj\"/>", "<geom type=\"mesh\" mesh=\"p\"/>"),
             "pentagon pyramid");
}

TEST_F(PhysicsOnly, NumberFormatsEqualFullCompile) {
  // A blob whose coordinates are written in every number form tinyobjloader reads.
  std::string blob = BlobObj({});
  std::string out;
  std::istringstream in(blob);
  int k = 0;
  for (std::string line; std::getline(in, line);) {
    if (line.rfind("v ", 0) == 0) {
      double x, y, z;
      std::sscanf(line.c_str(), "v %lf %lf %lf", &x, &y, &z);
      char buf[200];
      switch (k++ % 5) {
        case 0:
          std::snprintf(buf, sizeof buf, "v %.9e %.3E %+.12f", x, y, z);
          break;
        case 1:
          std::snprintf(buf, sizeof buf, "v\t%.17g  %.1f\t%.15f 1.0", x, y, z);
          break;
        case 2:
          std::snprintf(buf, sizeof buf, "v %.6e %.8f %.20f", x, y, z);
          break;
        case 3:
          std::snprintf(buf, sizeof buf, "v %.0f%s %.5g %.4e", x * 1000, "e-3", y, z);
          break;
        default:
          std::snprintf(buf, sizeof buf, "v %.10f %.10f %.10f", x, y, z);
      }
      out += buf;
    } else {
      out += line;
    }
    out += "\n";
  }
  fs::path obj = Write("formats.obj", out);
  ExpectSame(Asset("<mesh name=\"f\" file=\"formats.obj\"/>", "<geom type=\"mesh\" mesh=\"f\"/>"),
             "number formats");
}

TEST_F(PhysicsOnly, SeveralObjectsEqualFullCompile) {
  std::string two = BlobObj({}) + "o second\nv 5 5 5\nv 6 5 5\nv 5 6 5\nf -1 -2 -3\n";
  fs::path obj = Write("two.obj", two);
  ExpectSame(Asset("<mesh name=\"t\" file=\"two.obj\"/>", "<geom type=\"mesh\" mesh=\"t\"/>"),
             "two objects");
}

TEST_F(PhysicsOnly, InconsistentOrientationIsMuJoCosErrorForExactInertia) {
  std::string tet = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 2 3\nf 1 2 4\nf 2 3 4\nf 3 1 4\n";
  Write("tet.obj", tet);
  // MuJoCo's default (legacy) mesh inertia accepts it, the same either way.
  ExpectSame(Asset("<mesh name=\"t\" file=\"tet.obj\"/>", "<geom type=\"mesh\" mesh=\"t\"/>"),
             "inconsistent tetrahedron");
  fs::path xml = Asset("<mesh name=\"t\" file=\"tet.obj\" inertia=\"exact\"/>",
                       "<geom type=\"mesh\" mesh=\"t\"/>");
  for (bool fast : {true, false}) {
    try {
      ComputeAssetFacts(xml, fast);
      ADD_FAILURE() << "accepted";
    } catch (const Error& e) {
      EXPECT_THAT(e.what(), HasSubstr("inconsistent orientation")) << fast;
    }
  }
}

TEST_F(PhysicsOnly, MalformedObjIsMuJoCosErrorInOneLineNamingTheAssetFile) {
  const std::string good = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\n";
  struct Case {
    std::string text, line, message;
  };
  std::vector<Case> cases = {
      {"v 0 0 0\nv 1 x 0\n", "line 1, element <mesh>", "at least 4 vertices"},
      {"v 0 0\n", "line 1, element <mesh>", "at least 4 vertices"},
      {good + "f 1 2 3\nf 1 2 9\n", "line 1, element <mesh>", "does not exist"},
      {good + "f 1 0 3\n", "line 1, element <mesh>", "could not parse OBJ"},
      {good + "f 1 a 3\n", "line 1, element <mesh>", "could not parse OBJ"},
      {"v 0 0 0\nf -2 -1 1\n" + good, "line 1, element <mesh>", "does not exist"},
      {good + "# comment\n\nf 1 2 3 \nf 1/1/1 2/ 3\nf 99999999999999 1 2\n", "line 1",
       "does not exist"},
  };
  for (const Case& c : cases) {
    Write("bad.obj", c.text);
    fs::path xml = Asset("<mesh name=\"b\" file=\"bad.obj\"/>", "<geom type=\"mesh\" mesh=\"b\"/>");
    try {
      ComputeAssetFacts(xml, true);
      ADD_FAILURE() << "accepted: " << c.text;
    } catch (const Error& e) {
      std::string what = e.what();
      EXPECT_THAT(what, HasSubstr(xml.string())) << c.text;
      EXPECT_THAT(what, HasSubstr(c.line)) << c.text;
      EXPECT_THAT(what, HasSubstr(c.message)) << c.text;
      EXPECT_THAT(what, Not(HasSubstr("\n"))) << c.text;
    }
  }
}

TEST_F(PhysicsOnly, TruncatedAndGarbageFilesNeverCrash) {
  BlobOptions o;
  o.quads = true;
  const std::string obj = BlobObj(o);
  std::mt19937 rng(7);
  for (int k = 0; k < 40; ++k) {
    std::string text = obj.substr(0, rng() % obj.size());
    if (k % 2) text[rng() % text.size()] = static_cast<char>(rng());
    Write("g.obj", text);
    fs::path xml = Asset("<mesh name=\"g\" file=\"g.obj\"/>", "<geom type=\"mesh\" mesh=\"g\"/>");
    try {
      AssetFacts f = ComputeAssetFacts(xml, true);
      EXPECT_GE(f.mass, 0);
    } catch (const Error& e) {
      EXPECT_THAT(std::string(e.what()), Not(HasSubstr("\n")));
    }
  }
}

}  // namespace
}  // namespace mlspaces::sim
