#include "solid/render/query_views.h"

#include <OpenImageIO/imagebuf.h>
#include <OpenImageIO/imagebufalgo.h>

#include <algorithm>
#include <chrono>
#include <cmath>
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

// Crops `film` to [x0, x1) x [y0, y1) and resizes it, in linear light, to w x h.
Result<Image8> CropAndResize(const Film& film, int x0, int y0, int x1, int y1, int w, int h, std::string_view where) {
  const OIIO::ImageSpec spec(film.width, film.height, 3, OIIO::TypeDesc::FLOAT);
  const OIIO::ImageBuf full(spec, const_cast<float*>(film.rgb.data()));
  const OIIO::ImageBuf crop = OIIO::ImageBufAlgo::cut(full, OIIO::ROI(x0, x1, y0, y1, 0, 1, 0, 3));
  const OIIO::ImageBuf resized = OIIO::ImageBufAlgo::resize(crop, "", 0, OIIO::ROI(0, w, 0, h, 0, 1, 0, 3));
  if (resized.has_error() || crop.has_error()) {
    return InternalError(fmt::format("{}: resize failed: {}{}", where, crop.geterror(), resized.geterror()));
  }
  Film small;
  small.width = w;
  small.height = h;
  small.rgb.resize(static_cast<size_t>(w) * h * 3);
  if (!resized.get_pixels(OIIO::ROI(0, w, 0, h, 0, 1, 0, 3), OIIO::TypeDesc::FLOAT, small.rgb.data())) {
    return InternalError(fmt::format("{}: resize failed: {}", where, resized.geterror()));
  }
  return EncodeFilm(small);
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
  light.power_w = static_cast<float>(options.light_power_w * scale * scale);
  scene.lights.push_back(light);

  const int n = options.render_size;
  for (int v = 0; v < options.views; ++v) {
    const double azimuth = 360.0 * v / options.views;
    const double a = azimuth * kDegree;
    const Vec3 eye{-out.distance * std::sin(a), out.distance * std::cos(a), 0};
    Camera camera;
    if (!LookAt(eye, {0, 0, 0}, options.hfov_deg, n, n, &camera)) return InternalError(where + ": no camera");
    scene.lights[0].position = ToFloat(eye);
    const Film film = RenderFilm(scene, camera, n, n, 1e-3 * out.distance, FilmSampling{options.samples_per_pixel, {}},
                                 options.threads, MixSeed(seed, static_cast<uint64_t>(v)));
    int x0 = n, y0 = n, x1 = 0, y1 = 0;
    for (int y = 0; y < n; ++y) {
      for (int x = 0; x < n; ++x) {
        if (film.covered[static_cast<size_t>(y) * n + x] == 0) continue;
        x0 = std::min(x0, x), x1 = std::max(x1, x + 1), y0 = std::min(y0, y), y1 = std::max(y1, y + 1);
      }
    }
    if (x1 <= x0) {
      out.failed.push_back(azimuth);
      continue;
    }
    const int cw = x1 - x0, ch = y1 - y0;
    const int w = cw >= ch ? options.long_side : std::max(1, static_cast<int>(std::lround(1.0 * options.long_side * cw / ch)));
    const int h = ch >= cw ? options.long_side : std::max(1, static_cast<int>(std::lround(1.0 * options.long_side * ch / cw)));
    QueryView view;
    SOLID_ASSIGN_OR_RETURN(view.image, CropAndResize(film, x0, y0, x1, y1, w, h, where));
    view.azimuth_deg = azimuth;
    view.elevation_deg = 0;
    view.crop_x0 = x0, view.crop_y0 = y0, view.crop_x1 = x1, view.crop_y1 = y1;
    out.views.push_back(std::move(view));
  }
  out.ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  return out;
}

}  // namespace solid::render
