#include "solid/render/geometry.h"

#include <algorithm>
#include <limits>

namespace solid::render {

Mat3 operator*(const Mat3& a, const Mat3& b) {
  Mat3 r;
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) r.m[3 * i + j] = a(i, 0) * b(0, j) + a(i, 1) * b(1, j) + a(i, 2) * b(2, j);
  }
  return r;
}

Mat3 Mat3::Transposed() const { return Mat3{{m[0], m[3], m[6], m[1], m[4], m[7], m[2], m[5], m[8]}}; }

Mat3 RotationEulerXyz(double x, double y, double z) {
  const double cx = std::cos(x), sx = std::sin(x), cy = std::cos(y), sy = std::sin(y), cz = std::cos(z),
               sz = std::sin(z);
  const Mat3 rx{{1, 0, 0, 0, cx, -sx, 0, sx, cx}};
  const Mat3 ry{{cy, 0, sy, 0, 1, 0, -sy, 0, cy}};
  const Mat3 rz{{cz, -sz, 0, sz, cz, 0, 0, 0, 1}};
  return rz * (ry * rx);
}

Affine3x4 MakeAffine(const Mat3& rotation, double scale, Vec3 translation) {
  Affine3x4 a{};
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) a[4 * r + c] = rotation(r, c) * scale;
    a[4 * r + 3] = translation[r];
  }
  return a;
}

Vec3 Obb::Corner(int i) const {
  Vec3 p = center;
  for (int k = 0; k < 3; ++k) p = p + axes.Column(k) * ((i >> k & 1) != 0 ? half[k] : -half[k]);
  return p;
}

double Obb::WorldHalfExtent(int k) const {
  return std::fabs(axes(k, 0)) * half.x + std::fabs(axes(k, 1)) * half.y + std::fabs(axes(k, 2)) * half.z;
}

namespace {

// Projections of a box on `axis`: centre and radius.
double BoxRadius(const Obb& b, Vec3 axis) {
  return std::fabs(Dot(b.axes.Column(0), axis)) * b.half.x + std::fabs(Dot(b.axes.Column(1), axis)) * b.half.y +
         std::fabs(Dot(b.axes.Column(2), axis)) * b.half.z;
}

// True when `axis` separates strictly; near-zero cross products (parallel edges) are
// skipped, the face axes already cover them.
bool Separates(const Obb& a, const Obb& b, Vec3 axis) {
  const double len2 = Dot(axis, axis);
  if (len2 < 1e-18) return false;
  const double distance = std::fabs(Dot(b.center - a.center, axis));
  return distance > BoxRadius(a, axis) + BoxRadius(b, axis);
}

bool SeparatesTriangle(const Obb& box, const std::array<Vec3, 3>& t, Vec3 axis) {
  if (Dot(axis, axis) < 1e-18) return false;
  double lo = std::numeric_limits<double>::infinity(), hi = -lo;
  for (const Vec3& v : t) {
    const double p = Dot(v - box.center, axis);
    lo = std::min(lo, p);
    hi = std::max(hi, p);
  }
  const double r = BoxRadius(box, axis);
  return lo > r || hi < -r;
}

}  // namespace

bool Intersects(const Obb& a, const Obb& b) {
  for (int i = 0; i < 3; ++i) {
    if (Separates(a, b, a.axes.Column(i)) || Separates(a, b, b.axes.Column(i))) return false;
  }
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) {
      if (Separates(a, b, Cross(a.axes.Column(i), b.axes.Column(j)))) return false;
    }
  }
  return true;
}

bool Intersects(const Obb& box, Vec3 t0, Vec3 t1, Vec3 t2) {
  const std::array<Vec3, 3> t = {t0, t1, t2};
  const std::array<Vec3, 3> edges = {t1 - t0, t2 - t1, t0 - t2};
  for (int i = 0; i < 3; ++i) {
    if (SeparatesTriangle(box, t, box.axes.Column(i))) return false;
  }
  if (SeparatesTriangle(box, t, Cross(edges[0], edges[1]))) return false;
  for (int i = 0; i < 3; ++i) {
    for (const Vec3& e : edges) {
      if (SeparatesTriangle(box, t, Cross(box.axes.Column(i), e))) return false;
    }
  }
  return true;
}

bool RayInterval(Vec3 origin, Vec3 direction, const Obb& box, double* t_enter, double* t_exit) {
  double lo = -std::numeric_limits<double>::infinity(), hi = std::numeric_limits<double>::infinity();
  const Vec3 d = origin - box.center;
  for (int k = 0; k < 3; ++k) {
    const Vec3 axis = box.axes.Column(k);
    const double o = Dot(d, axis), v = Dot(direction, axis);
    if (std::fabs(v) < 1e-300) {
      if (std::fabs(o) > box.half[k]) return false;
      continue;
    }
    double a = (-box.half[k] - o) / v, b = (box.half[k] - o) / v;
    if (a > b) std::swap(a, b);
    lo = std::max(lo, a);
    hi = std::min(hi, b);
    if (lo > hi) return false;
  }
  *t_enter = lo;
  *t_exit = hi;
  return true;
}

}  // namespace solid::render
