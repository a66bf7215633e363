// Small double-precision geometry for layouts: vectors, rotations, oriented boxes
// and the separating-axis tests that keep placed objects apart (solid-method.md
// D2, D3: exact tests, touching counts as intersecting).
#pragma once

#include <array>
#include <cmath>

#include "solid/formats/records.h"

namespace solid::render {

struct Vec3 {
  double x = 0, y = 0, z = 0;
  double operator[](int i) const { return i == 0 ? x : (i == 1 ? y : z); }
  friend Vec3 operator+(Vec3 a, Vec3 b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
  friend Vec3 operator-(Vec3 a, Vec3 b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
  friend Vec3 operator*(Vec3 a, double s) { return {a.x * s, a.y * s, a.z * s}; }
  friend Vec3 operator*(double s, Vec3 a) { return a * s; }
  friend bool operator==(const Vec3&, const Vec3&) = default;
};
inline double Dot(Vec3 a, Vec3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
inline Vec3 Cross(Vec3 a, Vec3 b) { return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x}; }
inline double Length(Vec3 a) { return std::sqrt(Dot(a, a)); }
inline Vec3 Normalize(Vec3 a) { return a * (1.0 / Length(a)); }

// Row-major 3x3 matrix.
struct Mat3 {
  std::array<double, 9> m = {1, 0, 0, 0, 1, 0, 0, 0, 1};
  double operator()(int row, int col) const { return m[3 * row + col]; }
  Vec3 Column(int c) const { return {m[c], m[3 + c], m[6 + c]}; }
  friend Vec3 operator*(const Mat3& a, Vec3 v) {
    return {a.m[0] * v.x + a.m[1] * v.y + a.m[2] * v.z, a.m[3] * v.x + a.m[4] * v.y + a.m[5] * v.z,
            a.m[6] * v.x + a.m[7] * v.y + a.m[8] * v.z};
  }
  friend Mat3 operator*(const Mat3& a, const Mat3& b);
  Mat3 Transposed() const;
  friend bool operator==(const Mat3&, const Mat3&) = default;
};

// R = Rz(z) * Ry(y) * Rx(x): Blender's "XYZ" Euler order, as the reference samples it.
Mat3 RotationEulerXyz(double x, double y, double z);

// World from object: rotation times uniform scale, then translation.
Affine3x4 MakeAffine(const Mat3& rotation, double scale, Vec3 translation);

// An oriented box: centre, unit axes (the columns of `axes`) and half extents along them.
struct Obb {
  Vec3 center;
  Mat3 axes;
  Vec3 half;
  Vec3 Corner(int i) const;  // i in [0, 8): bit k picks the sign along axis k
  double HalfDiagonal() const { return Length(half); }
  // Half extent of the box's projection on the world axis `k`.
  double WorldHalfExtent(int k) const;
};

// 15-axis separating-axis test; boxes that touch intersect.
bool Intersects(const Obb& a, const Obb& b);
// 13-axis separating-axis test (Akenine-Moeller); a touching triangle intersects.
bool Intersects(const Obb& box, Vec3 t0, Vec3 t1, Vec3 t2);
// The parameter interval [*t_enter, *t_exit] where origin + t * direction lies in the
// box (slabs method), when it is non-empty; t may be negative.
bool RayInterval(Vec3 origin, Vec3 direction, const Obb& box, double* t_enter, double* t_exit);

}  // namespace solid::render
