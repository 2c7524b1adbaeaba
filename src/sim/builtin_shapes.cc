#include "builtin_shapes.h"

#include <mujoco/mujoco.h>

#include <cmath>

namespace mlspaces::sim {
namespace {

struct Vertex {
  float v[3];
  float n[3];
};

class Builder {
 public:
  explicit Builder(std::vector<float>* out) : out_(out) {}
  void Triangle(const Vertex& a, const Vertex& b, const Vertex& c) {
    for (const Vertex* p : {&a, &b, &c}) {
      out_->insert(out_->end(), p->v, p->v + 3);
      out_->insert(out_->end(), p->n, p->n + 3);
    }
  }
  // GL_QUADS' corners in order, as two triangles with the same winding.
  void Quad(const Vertex& a, const Vertex& b, const Vertex& c, const Vertex& d) {
    Triangle(a, b, c);
    Triangle(a, c, d);
  }

 private:
  std::vector<float>* out_;
};

Vertex SphereVertex(float az, float el, int sign) {
  Vertex p;
  p.v[0] = cosf(az) * cosf(el);
  p.v[1] = sinf(az) * cosf(el);
  p.v[2] = sign + sinf(el);
  p.n[0] = p.v[0];
  p.n[1] = p.v[1];
  p.n[2] = p.v[2] - sign;
  return p;
}

Vertex Pole(float z, float nz) { return {{0, 0, z}, {0, 0, nz}}; }

// halfSphere(): +1 top, -1 bottom, a unit sphere centred at (0, 0, sign).
void HalfSphere(Builder& b, int sign, int slices, int stacks) {
  float el1 = (mjPI / 2.0f * sign * (stacks - 1)) / static_cast<float>(stacks);
  for (int j = 0; j < slices; j++) {
    const float az1 = (2.0f * mjPI * (j + 0.0f)) / static_cast<float>(slices);
    const float az2 = (2.0f * mjPI * (j + 1.0f)) / static_cast<float>(slices);
    const Vertex v1 = SphereVertex(az1, el1, sign), v2 = SphereVertex(az2, el1, sign);
    const Vertex v3 = Pole(2.0f * sign, static_cast<float>(sign));
    if (sign > 0) {
      b.Triangle(v1, v2, v3);
    } else {
      b.Triangle(v3, v2, v1);
    }
  }
  for (int i = 0; i < stacks - 1; i++) {
    el1 = (mjPI / 2.0f * sign * (i + 0)) / static_cast<float>(stacks);
    const float el2 = (mjPI / 2.0f * sign * (i + 1)) / static_cast<float>(stacks);
    for (int j = 0; j < slices; j++) {
      const float az1 = (2.0f * mjPI * (j + 0)) / static_cast<float>(slices);
      const float az2 = (2.0f * mjPI * (j + 1)) / static_cast<float>(slices);
      const Vertex v1 = SphereVertex(az1, el1, sign), v2 = SphereVertex(az2, el1, sign);
      const Vertex v3 = SphereVertex(az2, el2, sign), v4 = SphereVertex(az1, el2, sign);
      if (sign > 0) {
        b.Quad(v1, v2, v3, v4);
      } else {
        b.Quad(v4, v3, v2, v1);
      }
    }
  }
}

// sphere(): the unit sphere.
void Sphere(Builder& b, int slices, int stacks) {
  const int half = stacks / 2;  // render_context.c's integer stacks/2
  for (int sign = -1; sign <= 1; sign += 2) {
    const float el1 = (0.5 * mjPI * sign * (half - 1)) / static_cast<float>(half);
    for (int j = 0; j < slices; j++) {
      const float az1 = (2.0f * mjPI * (j + 0.0f)) / static_cast<float>(slices);
      const float az2 = (2.0f * mjPI * (j + 1.0f)) / static_cast<float>(slices);
      const Vertex v1 = SphereVertex(az1, el1, 0), v2 = SphereVertex(az2, el1, 0);
      const Vertex v3 = Pole(static_cast<float>(sign), static_cast<float>(sign));
      if (sign > 0) {
        b.Triangle(v1, v2, v3);
      } else {
        b.Triangle(v3, v2, v1);
      }
    }
  }
  for (int sign = -1; sign <= 1; sign += 2) {
    for (int i = 0; i < half - 1; i++) {
      const float el1 = (0.5 * mjPI * sign * (i + 0)) / static_cast<float>(half);
      const float el2 = (0.5 * mjPI * sign * (i + 1)) / static_cast<float>(half);
      for (int j = 0; j < slices; j++) {
        const float az1 = (2.0f * mjPI * (j + 0)) / static_cast<float>(slices);
        const float az2 = (2.0f * mjPI * (j + 1)) / static_cast<float>(slices);
        const Vertex v1 = SphereVertex(az1, el1, 0), v2 = SphereVertex(az2, el1, 0);
        const Vertex v3 = SphereVertex(az2, el2, 0), v4 = SphereVertex(az1, el2, 0);
        if (sign > 0) {
          b.Quad(v1, v2, v3, v4);
        } else {
          b.Quad(v4, v3, v2, v1);
        }
      }
    }
  }
}

Vertex DiskVertex(float az, float r, int sign) {
  const float nz = sign == 0 ? -1.0f : static_cast<float>(sign);
  return {{cosf(az) * r, sinf(az) * r, static_cast<float>(sign)}, {0, 0, nz}};
}

// disk(): +1 top, -1 bottom.
void Disk(Builder& b, int sign, int slices, int stacks) {
  const float nz = sign == 0 ? -1.0f : static_cast<float>(sign);
  float r1 = 1.0f / static_cast<float>(stacks);
  for (int j = 0; j < slices; j++) {
    const float az1 = (2.0f * mjPI * (j + 0)) / static_cast<float>(slices);
    const float az2 = (2.0f * mjPI * (j + 1)) / static_cast<float>(slices);
    const Vertex v1 = DiskVertex(az1, r1, sign), v2 = DiskVertex(az2, r1, sign);
    const Vertex v3 = {{0, 0, static_cast<float>(sign)}, {0, 0, nz}};
    if (sign > 0) {
      b.Triangle(v1, v2, v3);
    } else {
      b.Triangle(v3, v2, v1);
    }
  }
  for (int i = 0; i < stacks - 1; i++) {
    r1 = (i + 1) / static_cast<float>(stacks);
    const float r2 = (i + 2) / static_cast<float>(stacks);
    for (int j = 0; j < slices; j++) {
      const float az1 = (2.0f * mjPI * (j + 0)) / static_cast<float>(slices);
      const float az2 = (2.0f * mjPI * (j + 1)) / static_cast<float>(slices);
      const Vertex v1 = DiskVertex(az1, r2, sign), v2 = DiskVertex(az2, r2, sign);
      const Vertex v3 = DiskVertex(az2, r1, sign), v4 = DiskVertex(az1, r1, sign);
      if (sign > 0) {
        b.Quad(v1, v2, v3, v4);
      } else {
        b.Quad(v4, v3, v2, v1);
      }
    }
  }
}

Vertex CylinderVertex(float az, float h) {
  Vertex p;
  p.v[0] = cosf(az);
  p.v[1] = sinf(az);
  p.v[2] = h;
  const float len = sqrtf(p.v[0] * p.v[0] + p.v[1] * p.v[1]);
  p.n[0] = p.v[0] / len;
  p.n[1] = p.v[1] / len;
  p.n[2] = 0;
  return p;
}

// cylinder(): open, from -1 to +1 in z, radius 1.
void Cylinder(Builder& b, int slices, int stacks) {
  for (int i = 0; i < stacks; i++) {
    const float h1 = 2 * (i + 0) / static_cast<float>(stacks) - 1;
    const float h2 = 2 * (i + 1) / static_cast<float>(stacks) - 1;
    for (int j = 0; j < slices; j++) {
      const float az1 = (2.0f * mjPI * (j + 0)) / static_cast<float>(slices);
      const float az2 = (2.0f * mjPI * (j + 1)) / static_cast<float>(slices);
      b.Quad(CylinderVertex(az1, h1), CylinderVertex(az2, h1), CylinderVertex(az2, h2),
             CylinderVertex(az1, h2));
    }
  }
}

void Box(Builder& b, int quads) {
  const float d = 2.0f / quads;
  auto v = [](float x, float y, float z, float nx, float ny, float nz) {
    return Vertex{{x, y, z}, {nx, ny, nz}};
  };
  for (int x = 0; x < quads; x++) {
    for (int y = 0; y < quads; y++) {
      const float a0 = d * (x + 0) - 1, a1 = d * (x + 1) - 1;
      const float b0 = d * (y + 0) - 1, b1 = d * (y + 1) - 1;
      b.Quad(v(a0, b0, 1, 0, 0, 1), v(a1, b0, 1, 0, 0, 1), v(a1, b1, 1, 0, 0, 1),
             v(a0, b1, 1, 0, 0, 1));  // top
      b.Quad(v(a0, b1, -1, 0, 0, -1), v(a1, b1, -1, 0, 0, -1), v(a1, b0, -1, 0, 0, -1),
             v(a0, b0, -1, 0, 0, -1));  // bottom
      b.Quad(v(1, a0, b0, 1, 0, 0), v(1, a1, b0, 1, 0, 0), v(1, a1, b1, 1, 0, 0),
             v(1, a0, b1, 1, 0, 0));  // right
      b.Quad(v(-1, a0, b1, -1, 0, 0), v(-1, a1, b1, -1, 0, 0), v(-1, a1, b0, -1, 0, 0),
             v(-1, a0, b0, -1, 0, 0));  // left
      b.Quad(v(a0, -1, b0, 0, -1, 0), v(a1, -1, b0, 0, -1, 0), v(a1, -1, b1, 0, -1, 0),
             v(a0, -1, b1, 0, -1, 0));  // front
      b.Quad(v(a0, 1, b1, 0, 1, 0), v(a1, 1, b1, 0, 1, 0), v(a1, 1, b0, 0, 1, 0),
             v(a0, 1, b0, 0, 1, 0));  // back
    }
  }
}

}  // namespace

BuiltinShapes MakeBuiltinShapes(int numslices, int numstacks, int numquads, int cylinder_stacks) {
  if (cylinder_stacks <= 0) cylinder_stacks = numstacks;
  BuiltinShapes s;
  Builder b(&s.vertices);
  auto shape = [&](BuiltinShape which, auto&& make) {
    const int first = static_cast<int>(s.vertices.size() / 6);
    make();
    s.ranges[which] = {first, static_cast<int>(s.vertices.size() / 6) - first};
  };
  shape(kShapeSphere, [&] { Sphere(b, numslices, numstacks); });
  shape(kShapeSphereTop, [&] { HalfSphere(b, +1, numslices, numstacks / 2); });
  shape(kShapeSphereBottom, [&] { HalfSphere(b, -1, numslices, numstacks / 2); });
  shape(kShapeCylinder, [&] {
    Disk(b, -1, numslices, numstacks / 2);
    Cylinder(b, numslices, cylinder_stacks);
    Disk(b, +1, numslices, numstacks / 2);
  });
  shape(kShapeCylinderOpen, [&] { Cylinder(b, numslices, cylinder_stacks); });
  shape(kShapeHaze, [] {});
  shape(kShapeBox, [&] { Box(b, numquads); });
  return s;
}

}  // namespace mlspaces::sim
