#include "solid/render/query_views.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <numbers>

#include <fmt/format.h>

#include "instance_scene.h"
#include "shading.h"
#include "solid/formats/random.h"
#include "streams.h"

namespace solid::render {

namespace {

constexpr double kPi = std::numbers::pi;
constexpr double kDegree = kPi / 180;
constexpr float kWorldGrey = 0.05f;
constexpr double kReferenceDistance = 3.0;  // the reference's fixed turntable radius, metres
constexpr double kFitShare = 0.8;           // D16: the bounding sphere spans this share of the frame

// Owns the reference rtcGetSceneDevice hands out.
class SceneDevice {
 public:
  explicit SceneDevice(RTCScene scene) : device_(rtcGetSceneDevice(scene)) {}
  ~SceneDevice() { rtcReleaseDevice(device_); }
  SceneDevice(const SceneDevice&) = delete;
  SceneDevice& operator=(const SceneDevice&) = delete;
  RTCDevice get() const { return device_; }

 private:
  RTCDevice device_;
};

// The vertices the model's triangles use: its silhouette's extent in any view lies
// within theirs.
std::vector<Vec3> TriangleVertices(const MeshGeometry& mesh) {
  std::vector<uint8_t> used(mesh.VertexCount(), 0);
  for (const uint32_t i : mesh.indices) {
    if (i < used.size()) used[i] = 1;
  }
  std::vector<Vec3> out;
  for (size_t i = 0; i < used.size(); ++i) {
    if (used[i]) out.push_back({mesh.positions[3 * i], mesh.positions[3 * i + 1], mesh.positions[3 * i + 2]});
  }
  return out;
}

// The rectangle of `camera`'s n x n frame that the projected model spans: its vertices'
// bounding box, clipped to the frame. The whole frame if a vertex lies behind the near
// plane (never with the fitted framing).
struct FrameRect {
  double x0 = 0, y0 = 0, x1 = 0, y1 = 0;
};
FrameRect ProjectedExtent(const std::vector<Vec3>& vertices, const Mat3& rotation, const Camera& camera, int n,
                          double near) {
  const double frame = n;
  FrameRect r{frame, frame, 0, 0};
  for (const Vec3& p : vertices) {
    double u = 0, v = 0;
    if (!Project(camera, rotation * p, near, &u, &v)) return {0, 0, frame, frame};
    r.x0 = std::min(r.x0, u), r.x1 = std::max(r.x1, u), r.y0 = std::min(r.y0, v), r.y1 = std::max(r.y1, v);
  }
  r.x0 = std::max(r.x0, 0.0), r.y0 = std::max(r.y0, 0.0), r.x1 = std::min(r.x1, frame), r.y1 = std::min(r.y1, frame);
  return r;
}

}  // namespace

Result<QueryViewsResult> RenderQueryViews(const std::shared_ptr<const LoadedAsset>& model, uint64_t seed,
                                          const QueryViewOptions& options, TextureCache& textures) {
  const auto start = std::chrono::steady_clock::now();
  if (model == nullptr) return InvalidArgumentError("query views: no model");
  const std::string where = "query views of " + model->key();
  if (options.views < 1 || options.views > 360 || options.render_size < 8 || options.render_size > 8192 ||
      options.long_side < 1 || options.long_side > 8192 || !(options.hfov_deg > 0 && options.hfov_deg < 180) ||
      options.samples_per_pixel < 1 || options.samples_per_pixel > 1024 || !(options.light_power_w >= 0)) {
    return InvalidArgumentError(fmt::format("{}: options out of range (views {}, render_size {}, long_side {}, "
                                            "hfov_deg {}, samples_per_pixel {}, light_power_w {})",
                                            where, options.views, options.render_size, options.long_side,
                                            options.hfov_deg, options.samples_per_pixel, options.light_power_w));
  }
  const double radius = Length(model->half_extents());
  if (!(radius > 0)) return InvalidArgumentError(where + ": the model has no extent");

  QueryViewsResult out;
  Rng rng(seed, kQueryStream);
  out.euler_xyz_deg = {-30.0, rng.Uniform(-180, 180), rng.Uniform(-180, 180)};
  const Mat3 rotation =
      RotationEulerXyz(out.euler_xyz_deg[0] * kDegree, out.euler_xyz_deg[1] * kDegree, out.euler_xyz_deg[2] * kDegree);
  out.distance = radius / (kFitShare * std::tan(options.hfov_deg * kDegree / 2));

  SOLID_ASSIGN_OR_RETURN(auto tex, textures.Get(model->textures(), model, model->key()));
  ShadingScene scene;
  scene.surfaces.push_back({&model->mesh(), &model->materials(), tex.get(), rotation, 1.0, Vec3{}});
  const RTCScene bottom = reinterpret_cast<RTCScene>(model->scene());
  const SceneInstance instance{bottom, MakeAffine(rotation, 1.0, Vec3{})};
  const SceneDevice device(bottom);
  const ObjectScene top(device.get(), {&instance, 1});
  scene.scene = top.get();
  scene.ambient = {kWorldGrey, kWorldGrey, kWorldGrey};
  scene.background = scene.ambient;
  // Self-occlusion of the world light over the whole model.
  scene.ambient_occlusion_m = static_cast<float>(2 * radius);
  const double scale = out.distance / kReferenceDistance;
  ShadingLight light;
  light.area = false;
  light.at_eye = true;  // placed at each view's eye below
  light.power_w = static_cast<float>(options.light_power_w * scale * scale);
  scene.lights.push_back(light);

  const int n = options.render_size;
  const double near = 1e-3 * out.distance;
  const std::vector<Vec3> vertices = TriangleVertices(model->mesh());
  for (int v = 0; v < options.views; ++v) {
    const double azimuth = 360.0 * v / options.views;
    const double a = azimuth * kDegree;
    const Vec3 eye{-out.distance * std::sin(a), out.distance * std::cos(a), 0};
    Camera camera;
    if (!LookAt(eye, {0, 0, 0}, options.hfov_deg, n, n, &camera)) return InternalError(where + ": no camera");
    scene.lights[0].position = ToFloat(eye);
    const FrameRect crop = ProjectedExtent(vertices, rotation, camera, n, near);
    const double cw = crop.x1 - crop.x0, ch = crop.y1 - crop.y0;
    if (!(cw > 0 && ch > 0)) {
      out.failed.push_back(azimuth);
      continue;
    }
    const int w = cw >= ch ? options.long_side : std::max(1, static_cast<int>(std::lround(1.0 * options.long_side * cw / ch)));
    const int h = ch >= cw ? options.long_side : std::max(1, static_cast<int>(std::lround(1.0 * options.long_side * ch / cw)));
    // The crop, traced directly at w x h: pixel coordinate u of this camera is
    // crop.x0 + u * cw / w of the frame's. Rendering the whole frame and resizing the crop
    // (OpenImageIO) shaded about four times the pixels and took 48.6 ms per view against
    // 22.9 (512 views, one thread).
    Camera cropped = camera;
    cropped.fx = camera.fx * w / cw;
    cropped.cx = (camera.cx - crop.x0) * w / cw;
    cropped.fy = camera.fy * h / ch;
    cropped.cy = (camera.cy - crop.y0) * h / ch;
    const Film film = RenderFilm(scene, cropped, w, h, near, FilmSampling{options.samples_per_pixel, {}},
                                 options.threads, MixSeed(seed, static_cast<uint64_t>(v)));
    if (std::find(film.covered.begin(), film.covered.end(), 1) == film.covered.end()) {
      out.failed.push_back(azimuth);
      continue;
    }
    QueryView view;
    view.image = EncodeFilm(film);
    view.azimuth_deg = azimuth;
    view.elevation_deg = 0;
    view.crop_x0 = crop.x0, view.crop_y0 = crop.y0, view.crop_x1 = crop.x1, view.crop_y1 = crop.y1;
    out.views.push_back(std::move(view));
  }
  out.ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  return out;
}

}  // namespace solid::render
