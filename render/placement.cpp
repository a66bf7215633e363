#include "placement.h"

#include <algorithm>
#include <limits>
#include <utility>

#include "solid/render/layout.h"

namespace solid::render {

namespace {

// Beyond any rounding of the exact tests, in metres: their terms are a few metres, their
// errors below 1e-12 m.
constexpr double kSlack = 1e-7;
constexpr double kRounding = 1e-12;

// The heights z at which column (x, y) is in front of the camera by more than the near
// distance and inside the inset frustum, widened by kSlack: each condition is linear in
// z, so they meet in one interval (empty when lo > hi).
std::pair<double, double> FrustumHeights(const LayoutParams& p, const Camera& camera, Vec3 eye, double x,
                                         double y) {
  const auto& a = camera.world_from_camera;
  const Vec3 right{a[0], a[4], a[8]}, up{a[1], a[5], a[9]}, forward{-a[2], -a[6], -a[10]};
  const Vec3 o{x - eye.x, y - eye.y, -eye.z};
  const double kx = p.frustum_inset * camera.cx / camera.fx, ky = p.frustum_inset * camera.cy / camera.fy;
  const double d0 = Dot(forward, o), d1 = forward.z;
  const double x0 = Dot(right, o), x1 = right.z, y0 = Dot(up, o), y1 = up.z;
  double lo = -std::numeric_limits<double>::infinity(), hi = std::numeric_limits<double>::infinity();
  // a + b z <= 0, with a known to kRounding: the bound moves by up to kRounding / |b|.
  auto keep = [&](double a0, double b) {
    if (b > 0) {
      hi = std::min(hi, (-a0 + kRounding) / b + kSlack);
    } else if (b < 0) {
      lo = std::max(lo, (-a0 + kRounding) / b - kSlack);
    } else if (a0 > kRounding) {
      lo = std::numeric_limits<double>::infinity();
    }
  };
  keep(p.camera_near_m - d0, -d1);  // depth d > near
  keep(x0 - kx * d0, x1 - kx * d1);  // |x| <= kx d
  keep(-x0 - kx * d0, -x1 - kx * d1);
  keep(y0 - ky * d0, y1 - ky * d1);  // |y| <= ky d
  keep(-y0 - ky * d0, -y1 - ky * d1);
  return {lo, hi};
}

}  // namespace

PlacementCandidates ListCandidates(const LayoutParams& p, const RoomShell& room, const Camera& camera) {
  PlacementCandidates out;
  const Vec3 eye = CameraPosition(camera);
  const bool floor = p.support == Support::kFloor;
  const int n = room.points(), k_max = room.TopLevel();
  const double min_hdist = std::max(0.0, p.min_hdist_m - kSlack);
  const double step = room.Z(1);
  for (int j = 0; j < n; ++j) {
    for (int i = 0; i < n; ++i) {
      if (!room.Covered(i, j)) continue;
      const double x = room.X(i), y = room.Y(j);
      const double dx = x - eye.x, dy = y - eye.y;
      if (!(dx * dx + dy * dy > min_hdist * min_hdist)) continue;
      auto [lo, hi] = FrustumHeights(p, camera, eye, x, y);
      if (floor) {
        const double base = room.FloorZ(i, j) + kFloorGap;
        lo = std::max(0.0, lo - base);
        hi -= base;
        if (lo <= hi) out.floor_columns.push_back({static_cast<uint16_t>(i), static_cast<uint16_t>(j), lo, hi});
        continue;
      }
      lo = std::max(lo, room.FloorZ(i, j) - kSlack);
      hi = std::min(hi, room.CeilingZ(i, j) + kSlack);
      if (!(lo <= hi)) continue;
      const int k0 = std::max(0, static_cast<int>(std::ceil(lo / step - 1e-9)));
      const int k1 = std::min(k_max, static_cast<int>(std::floor(hi / step + 1e-9)));
      for (int k = k0; k <= k1; ++k) {
        out.points.push_back({static_cast<uint16_t>(i), static_cast<uint16_t>(j), static_cast<uint16_t>(k)});
      }
    }
  }
  return out;
}

}  // namespace solid::render
