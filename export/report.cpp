#include "solid/export/report.h"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>
#include <nlohmann/json.hpp>
#include <span>
#include <vector>

#include "solid/formats/dataset.h"
#include "solid/formats/files.h"
#include "solid/formats/image_codec.h"
#include "solid/formats/metrics.h"
#include "solid/optimizer/optimize.h"
#include "solid/render/params.h"

namespace solid::exporters {
namespace {

namespace fs = std::filesystem;
using optimizer::Metric;

constexpr int kOcclusionBins = 10;
constexpr int kAzimuthBins = 36, kElevationBins = 18;  // 10 degrees each
// Instance colours of the overlays and of the query views' frames (Tableau 10).
constexpr std::array<std::array<uint8_t, 3>, 10> kPalette = {{{31, 119, 180}, {255, 127, 14}, {44, 160, 44},
                                                             {214, 39, 40}, {148, 103, 189}, {140, 86, 75},
                                                             {227, 119, 194}, {127, 127, 127}, {188, 189, 34},
                                                             {23, 190, 207}}};

std::string Escape(std::string_view s) {
  std::string out;
  for (char c : s) {
    switch (c) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      default: out += c;
    }
  }
  return out;
}

std::string Base64(std::span<const uint8_t> bytes) {
  static constexpr char kAlphabet[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  out.reserve((bytes.size() + 2) / 3 * 4);
  for (size_t i = 0; i < bytes.size(); i += 3) {
    const uint32_t n = (uint32_t{bytes[i]} << 16) | (i + 1 < bytes.size() ? uint32_t{bytes[i + 1]} << 8 : 0) |
                       (i + 2 < bytes.size() ? bytes[i + 2] : 0);
    out += kAlphabet[(n >> 18) & 63];
    out += kAlphabet[(n >> 12) & 63];
    out += i + 1 < bytes.size() ? kAlphabet[(n >> 6) & 63] : '=';
    out += i + 2 < bytes.size() ? kAlphabet[n & 63] : '=';
  }
  return out;
}

std::string DataUri(ImageFormat format, std::span<const uint8_t> bytes) {
  return fmt::format("data:image/{};base64,{}", ImageFormatName(format), Base64(bytes));
}

std::string Hex(const std::array<uint8_t, 3>& c) { return fmt::format("#{:02x}{:02x}{:02x}", c[0], c[1], c[2]); }

// What the plots show, gathered in one stream over the instances.
struct Stats {
  MetricsAccumulator metrics;
  std::array<int64_t, kOcclusionBins> occlusion{};
  std::array<int64_t, 3> scale{};
  std::vector<int64_t> objects;  // images by visible objects
  std::array<std::array<int64_t, kAzimuthBins>, kElevationBins> views{};
  std::vector<int64_t> image_ids;
  int64_t instances = 0;
};

int Bin(double v, double lo, double hi, int bins) {
  return std::clamp(static_cast<int>(std::floor((v - lo) / (hi - lo) * bins)), 0, bins - 1);
}

Result<Stats> Gather(Dataset& dataset) {
  const double area_scale = dataset.manifest().ScaleClassAreaScale();
  Stats s{MetricsAccumulator(area_scale)};
  for (const ShardFile& file : dataset.shards().targets) {
    SOLID_ASSIGN_OR_RETURN(ShardReader * shard, dataset.Shard(file.index));
    SOLID_ASSIGN_OR_RETURN(std::vector<int64_t> ids, shard->ImageIds());
    size_t next = 0;  // instances come in image order: count each image's as they pass
    int64_t all = 0, visible = 0;
    auto finish_images_until = [&](int64_t image_id) {
      for (; next < ids.size() && ids[next] < image_id; ++next) {
        if (s.objects.size() <= static_cast<size_t>(visible)) s.objects.resize(visible + 1);
        ++s.objects[visible];
        s.image_ids.push_back(ids[next]);
        all = visible = 0;
      }
    };
    SOLID_RETURN_IF_ERROR(shard->ForEachInstance(
        [&](const InstanceRecord& in) -> Status {
          finish_images_until(in.image_id);
          ++all;
          ++s.instances;
          if (in.visible_area == 0) return Status::Ok();
          ++visible;
          if (in.occlusion) ++s.occlusion[Bin(*in.occlusion, 0, 1, kOcclusionBins)];
          ++s.scale[static_cast<int>(ScaleClassOfArea(in.visible_area, area_scale))];
          ++s.views[Bin(in.view_elevation, -std::numbers::pi / 2, std::numbers::pi / 2, kElevationBins)]
                   [Bin(in.view_azimuth, -std::numbers::pi, std::numbers::pi, kAzimuthBins)];
          return Status::Ok();
        },
        ChecksumPolicy::kSkip));
    finish_images_until(INT64_MAX);
    SOLID_RETURN_IF_ERROR(shard->AddToMetrics(s.metrics));
  }
  return s;
}

// The preset whose layout params are the manifest's, resolution and scale-class
// resolution aside.
std::string DetectPreset(const Manifest& manifest) {
  if (!manifest.params.contains("layout")) return {};
  const nlohmann::json::json_pointer resolution("/render/resolution");
  nlohmann::json layout = manifest.params["layout"];
  if (layout.contains(resolution)) {
    layout.at(resolution.parent_pointer()).erase("resolution");
    layout.at(resolution.parent_pointer()).erase("scale_classes_at");
  }
  for (const std::string& name : render::PresetNames()) {
    Result<render::LayoutParams> preset = render::LoadPreset(name);
    if (!preset.ok()) continue;
    nlohmann::json p = render::ParamsToJson(*preset);
    if (p.contains(resolution)) p.at(resolution.parent_pointer()).erase("resolution");
    if (p == layout) return name;
  }
  return {};
}

std::string Format(Metric m, double v) {
  return m == Metric::kObjectsPerImage ? fmt::format("{:.2f}", v) : fmt::format("{:.1f}%", 100 * v);
}

// A bar chart: one bar per label, the count above it.
std::string BarChart(std::string_view title, std::string_view x_label, const std::vector<std::string>& labels,
                     const std::vector<int64_t>& counts) {
  constexpr double kW = 340, kH = 220, kLeft = 20, kBottom = 40, kTop = 28;
  const int64_t peak = std::max<int64_t>(1, *std::max_element(counts.begin(), counts.end()));
  const double slot = (kW - kLeft - 10) / static_cast<double>(counts.size());
  std::string svg = fmt::format(
      "<svg class=\"plot\" viewBox=\"0 0 {} {}\" width=\"{}\" height=\"{}\" role=\"img\" aria-label=\"{}\">"
      "<text x=\"{}\" y=\"16\" class=\"title\">{}</text>",
      kW, kH, kW, kH, Escape(title), kW / 2, Escape(title));
  const double plot_h = kH - kBottom - kTop;
  for (size_t i = 0; i < counts.size(); ++i) {
    const double h = plot_h * static_cast<double>(counts[i]) / static_cast<double>(peak);
    const double x = kLeft + slot * static_cast<double>(i);
    svg += fmt::format("<rect x=\"{:.1f}\" y=\"{:.1f}\" width=\"{:.1f}\" height=\"{:.1f}\" class=\"bar\">"
                       "<title>{}: {}</title></rect>",
                       x + 1, kTop + plot_h - h, slot - 2, h, Escape(labels[i]), counts[i]);
    if (counts.size() <= 12 && counts[i] > 0) {
      svg += fmt::format("<text x=\"{:.1f}\" y=\"{:.1f}\" class=\"count\">{}</text>", x + slot / 2,
                         kTop + plot_h - h - 3, counts[i]);
    }
    // Label every bar when they fit, else every other one.
    if (counts.size() <= 12 || i % 2 == 0) {
      svg += fmt::format("<text x=\"{:.1f}\" y=\"{:.1f}\" class=\"tick\">{}</text>", x + slot / 2,
                         kTop + plot_h + 14, Escape(labels[i]));
    }
  }
  svg += fmt::format("<line x1=\"{}\" y1=\"{}\" x2=\"{}\" y2=\"{}\" class=\"axis\"/>", kLeft, kTop + plot_h, kW - 10,
                     kTop + plot_h);
  svg += fmt::format("<text x=\"{}\" y=\"{}\" class=\"label\">{}</text></svg>", (kLeft + kW) / 2, kH - 6,
                     Escape(x_label));
  return svg;
}

// Viridis, by linear interpolation between five of its stops.
std::string Viridis(double t) {
  static constexpr std::array<std::array<double, 3>, 5> kStops = {
      {{68, 1, 84}, {59, 82, 139}, {33, 145, 140}, {94, 201, 98}, {253, 231, 37}}};
  const double x = std::clamp(t, 0.0, 1.0) * 4;
  const int i = std::min(3, static_cast<int>(x));
  const double f = x - i;
  std::array<uint8_t, 3> c;
  for (int k = 0; k < 3; ++k) c[k] = static_cast<uint8_t>(std::lround(kStops[i][k] * (1 - f) + kStops[i + 1][k] * f));
  return Hex(c);
}

std::string HeatMap(const Stats& s) {
  constexpr double kCell = 16, kLeft = 64, kTop = 30;
  constexpr double kW = kLeft + kAzimuthBins * kCell + 70, kH = kTop + kElevationBins * kCell + 44;
  int64_t peak = 1;
  for (const auto& row : s.views) peak = std::max(peak, *std::max_element(row.begin(), row.end()));
  std::string svg = fmt::format(
      "<svg class=\"plot\" viewBox=\"0 0 {} {}\" width=\"{}\" height=\"{}\" role=\"img\" aria-label=\"viewpoints\">"
      "<text x=\"{}\" y=\"18\" class=\"title\">Viewpoints of visible objects (camera direction in the object "
      "frame)</text>",
      kW, kH, kW, kH, kLeft + kAzimuthBins * kCell / 2);
  for (int e = 0; e < kElevationBins; ++e) {
    for (int a = 0; a < kAzimuthBins; ++a) {
      const int64_t n = s.views[e][a];
      // Square root: a few frontal views would otherwise leave the rest of the map dark.
      svg += fmt::format(
          "<rect x=\"{}\" y=\"{}\" width=\"{}\" height=\"{}\" fill=\"{}\"><title>azimuth {}..{}, elevation "
          "{}..{}: {}</title></rect>",
          kLeft + a * kCell, kTop + (kElevationBins - 1 - e) * kCell, kCell, kCell,
          Viridis(std::sqrt(static_cast<double>(n) / static_cast<double>(peak))), -180 + 10 * a, -170 + 10 * a,
          -90 + 10 * e, -80 + 10 * e, n);
    }
  }
  for (int a = 0; a <= kAzimuthBins; a += 6) {
    svg += fmt::format("<text x=\"{}\" y=\"{}\" class=\"tick\">{}°</text>", kLeft + a * kCell,
                       kTop + kElevationBins * kCell + 14, -180 + 10 * a);
  }
  for (int e = 0; e <= kElevationBins; e += 3) {
    svg += fmt::format("<text x=\"{}\" y=\"{}\" class=\"tick\" text-anchor=\"end\">{}°</text>", kLeft - 4,
                       kTop + (kElevationBins - e) * kCell + 4, -90 + 10 * e);
  }
  svg += fmt::format("<text x=\"{}\" y=\"{}\" class=\"label\">azimuth</text>", kLeft + kAzimuthBins * kCell / 2,
                     kH - 8);
  svg += fmt::format("<text x=\"16\" y=\"{}\" class=\"label\" transform=\"rotate(-90 16 {})\">elevation</text>",
                     kTop + kElevationBins * kCell / 2, kTop + kElevationBins * kCell / 2);
  const double bar_x = kLeft + kAzimuthBins * kCell + 16;
  for (int i = 0; i < 32; ++i) {
    svg += fmt::format("<rect x=\"{}\" y=\"{:.2f}\" width=\"12\" height=\"{:.2f}\" fill=\"{}\"/>", bar_x,
                       kTop + (31 - i) * kElevationBins * kCell / 32, kElevationBins * kCell / 32 + 0.5,
                       Viridis(i / 31.0));
  }
  svg += fmt::format("<text x=\"{}\" y=\"{}\" class=\"tick\" text-anchor=\"start\">{}</text>", bar_x + 16, kTop + 8,
                     peak);
  svg += fmt::format("<text x=\"{}\" y=\"{}\" class=\"tick\" text-anchor=\"start\">0</text></svg>", bar_x + 16,
                     kTop + kElevationBins * kCell);
  return svg;
}

// Draws a mask into `image`: its pixels tinted, its outline and box in the solid colour.
void DrawMask(Image8& image, const std::vector<uint8_t>& mask, const rle::Box& box, const std::array<uint8_t, 3>& c) {
  const uint32_t w = image.width, h = image.height, ch = image.channels;
  auto set = [&](uint32_t x, uint32_t y, double alpha) {
    uint8_t* p = &image.pixels[(static_cast<size_t>(y) * w + x) * ch];
    for (uint32_t k = 0; k < std::min(ch, 3u); ++k) p[k] = static_cast<uint8_t>(std::lround(p[k] * (1 - alpha) + c[k] * alpha));
  };
  auto in = [&](int64_t x, int64_t y) { return x >= 0 && y >= 0 && x < w && y < h && mask[y * w + x] != 0; };
  for (uint32_t y = 0; y < h; ++y) {
    for (uint32_t x = 0; x < w; ++x) {
      if (!in(x, y)) continue;
      const bool edge = !in(int64_t{x} - 1, y) || !in(x + 1, y) || !in(x, int64_t{y} - 1) || !in(x, y + 1);
      set(x, y, edge ? 1.0 : 0.45);
    }
  }
  // Lines about one pixel wide as the page shows the image (a third of its width or less).
  const int64_t thickness = std::max<int64_t>(1, w / 256);
  for (int64_t y = box.y; y < box.y + box.h; ++y) {
    for (int64_t x = box.x; x < box.x + box.w; ++x) {
      const bool border = x - box.x < thickness || box.x + box.w - 1 - x < thickness || y - box.y < thickness ||
                          box.y + box.h - 1 - y < thickness;
      if (border) set(static_cast<uint32_t>(x), static_cast<uint32_t>(y), 1);
    }
  }
}

Result<std::string> Overlay(const Image8& base, const std::vector<InstanceRecord>& instances, bool full,
                            const fs::path& where) {
  Image8 image = base;
  for (const InstanceRecord& in : instances) {
    const std::string& counts = full ? in.full_rle : in.visible_rle;
    Result<rle::Rle> mask = rle::FromString(counts, image.height, image.width);
    if (!mask.ok()) {
      return CorruptError(fmt::format("{}: image {} instance {}: {}", where.string(), in.image_id, in.ordinal,
                                      mask.status().message()));
    }
    DrawMask(image, rle::DecodeRowMajor(*mask), full ? in.full_box : in.visible_box,
             kPalette[static_cast<size_t>(in.ordinal) % kPalette.size()]);
  }
  SOLID_ASSIGN_OR_RETURN(std::vector<uint8_t> jpeg, EncodeImage(image, ImageFormat::kJpeg, 88));
  return DataUri(ImageFormat::kJpeg, jpeg);
}

Result<std::string> SampleCard(Dataset& dataset, int64_t image_id, int query_models) {
  const fs::path where = dataset.paths().shard(dataset.ShardOfImage(image_id));
  SOLID_ASSIGN_OR_RETURN(ImageRecord record, dataset.ReadImage(image_id));
  SOLID_ASSIGN_OR_RETURN(std::vector<InstanceRecord> all, dataset.Instances(image_id));
  SOLID_ASSIGN_OR_RETURN(Image8 image, DecodeImage(record.image, record.format));
  std::vector<InstanceRecord> visible;
  for (const InstanceRecord& in : all) {
    if (in.visible_area > 0) visible.push_back(in);
  }
  SOLID_ASSIGN_OR_RETURN(std::string visible_uri, Overlay(image, visible, false, where));
  SOLID_ASSIGN_OR_RETURN(std::string full_uri, Overlay(image, visible, true, where));
  std::string card = fmt::format(
      "<div class=\"card\" data-image-id=\"{}\"><div class=\"card-head\">image {} · {} visible of {} objects</div>"
      "<div class=\"pair\"><figure><img class=\"sample\" src=\"{}\" alt=\"image {} visible masks\">"
      "<figcaption>visible masks and boxes</figcaption></figure>"
      "<figure><img class=\"sample\" src=\"{}\" alt=\"image {} full masks\"><figcaption>full (amodal) masks and "
      "boxes</figcaption></figure></div><div class=\"queries\">",
      image_id, image_id, visible.size(), all.size(), visible_uri, image_id, full_uri, image_id);
  std::sort(visible.begin(), visible.end(),
            [](const InstanceRecord& a, const InstanceRecord& b) { return a.visible_area > b.visible_area; });
  int shown = 0;
  std::vector<std::string_view> models;
  for (const InstanceRecord& in : visible) {
    if (shown == query_models) break;
    // One view per model: an image may hold several copies of one.
    if (std::find(models.begin(), models.end(), in.model_key) != models.end()) continue;
    models.push_back(in.model_key);
    SOLID_ASSIGN_OR_RETURN(std::vector<QueryViewRecord> views, dataset.QueryViews(in.model_key));
    if (views.empty()) continue;
    ++shown;
    const QueryViewRecord& view = views.front();
    card += fmt::format(
        "<figure class=\"query\"><img src=\"{}\" alt=\"query view of {}\" style=\"border-color:{}\">"
        "<figcaption title=\"{}\">{}</figcaption></figure>",
        DataUri(view.format, view.image), Escape(in.model_key),
        Hex(kPalette[static_cast<size_t>(in.ordinal) % kPalette.size()]), Escape(in.model_key),
        Escape(in.model_key.substr(in.model_key.rfind('/') + 1)));
  }
  if (shown == 0) card += "<p class=\"muted\">no query views stored for these objects</p>";
  return card + "</div></div>";
}

constexpr std::string_view kStyle = R"css(
body{font:14px/1.45 system-ui,-apple-system,"Segoe UI",Roboto,sans-serif;margin:0;background:#f4f5f7;color:#1d2330}
header{background:#1d2330;color:#fff;padding:20px 32px}header h1{margin:0 0 4px;font-size:22px}
header .sub{color:#aab3c5}main{padding:8px 32px 40px;max-width:1400px}
section{background:#fff;border-radius:8px;box-shadow:0 1px 3px rgba(0,0,0,.08);padding:16px 20px;margin:16px 0}
h2{font-size:17px;margin:0 0 12px}table{border-collapse:collapse}td,th{padding:4px 14px 4px 0;text-align:left}
th{color:#5b6577;font-weight:600}td.num{text-align:right;font-variant-numeric:tabular-nums}
.ok{color:#1a7f37;font-weight:600}.bad{color:#cf222e;font-weight:600}.muted{color:#6b7385}
pre{background:#f6f8fa;padding:10px;border-radius:6px;max-height:360px;overflow:auto;font-size:12px}
.plots{display:flex;flex-wrap:wrap;gap:16px}.plot text{font-size:11px;fill:#3b4252;text-anchor:middle}
.plot .title{font-size:13px;font-weight:600}.plot .bar{fill:#4c78a8}.plot .bar:hover{fill:#f58518}
.plot .axis{stroke:#888}.plot .count{font-size:10px;fill:#5b6577}
.grid{display:grid;grid-template-columns:repeat(auto-fill,minmax(520px,1fr));gap:16px}
.card{border:1px solid #e1e4ea;border-radius:8px;padding:10px;background:#fafbfc}.card-head{font-weight:600;margin-bottom:6px}
.pair{display:flex;gap:8px}.pair figure{flex:1;margin:0}.sample{width:100%;image-rendering:auto;border-radius:4px}
figcaption{font-size:12px;color:#5b6577}.queries{display:flex;flex-wrap:wrap;gap:8px;margin-top:8px}
.query{margin:0;width:96px}.query img{width:92px;height:92px;object-fit:contain;border:2px solid;border-radius:4px;background:#fff}
.query figcaption{overflow:hidden;text-overflow:ellipsis;white-space:nowrap}
)css";

}  // namespace

nlohmann::json ReportSummary::ToJson() const {
  return {{"out", out.string()},   {"images", images},
          {"instances", instances}, {"samples", samples},
          {"target_row", target_row}, {"bytes", bytes},
          {"metrics", metrics.ToJson()}};
}

std::string ReportSummary::ToText() const {
  return fmt::format("{}: {} images, {} instances, {} samples, {}, {:.1f} MB\n", out.string(), images, instances,
                     samples, target_row.empty() ? "no targets" : "targets of " + target_row,
                     static_cast<double>(bytes) / 1e6);
}

Result<ReportSummary> WriteReport(const ReportOptions& options) {
  if (options.dataset.empty()) return OptionError("dataset", "no dataset directory given");
  if (options.out.empty()) return OptionError("out", "no .html file given");
  if (options.samples < 0 || options.samples > kMaxReportSamples) {
    return OptionError("samples", fmt::format("{} is not in [0, {}]", options.samples, kMaxReportSamples));
  }
  if (options.query_models < 0 || options.query_models > kMaxReportQueryModels) {
    return OptionError("query_models",
                       fmt::format("{} is not in [0, {}]", options.query_models, kMaxReportQueryModels));
  }
  SOLID_ASSIGN_OR_RETURN(Dataset dataset, Dataset::Open(options.dataset));
  const Manifest& m = dataset.manifest();
  SOLID_ASSIGN_OR_RETURN(Stats stats, Gather(dataset));
  const ProxyMetrics metrics = stats.metrics.Finish();

  ReportSummary summary;
  summary.out = options.out;
  summary.metrics = metrics;
  summary.images = metrics.images;
  summary.instances = stats.instances;
  summary.target_row = options.target_row == "none" ? "" : options.target_row.empty() ? DetectPreset(m) : options.target_row;
  std::vector<optimizer::Comparison> comparisons;
  if (!summary.target_row.empty()) {
    Result<std::vector<optimizer::Target>> targets = optimizer::TableRowTargets(summary.target_row);
    if (!targets.ok()) return OptionError("target_row", targets.status().message(), targets.status().code());
    comparisons = optimizer::CompareWithTargets(metrics, *targets);
  }

  std::string html = fmt::format(
      "<!DOCTYPE html><html lang=\"en\"><head><meta charset=\"utf-8\"><title>solid report: {}</title><style>{}</style>"
      "</head><body><header><h1>solid dataset report</h1><div class=\"sub\">{} · {} images · {} instances · "
      "{}x{} {}</div></header><main>",
      Escape(options.dataset.filename().string()), kStyle, Escape(options.dataset.string()), metrics.images,
      stats.instances, m.width, m.height, ImageFormatName(m.image_format));

  html += "<section id=\"manifest\"><h2>Manifest</h2><table>";
  const std::vector<std::pair<std::string, std::string>> rows = {
      {"generator", fmt::format("{} {}", m.generator_name, m.generator_version)},
      {"format version", std::to_string(m.format_version)},
      {"seed", std::to_string(m.seed)},
      {"images (planned / present)", fmt::format("{} / {}", m.images, metrics.images)},
      {"shards (size)", fmt::format("{} present of {} ({} images each)", dataset.shards().targets.size(),
                                    m.ShardCount(), m.shard_size)},
      {"query shards", std::to_string(dataset.shards().queries.size())},
      {"resolution", fmt::format("{}x{}", m.width, m.height)},
      {"scale classes counted at",
       fmt::format("{}x{}", m.ScaleClassResolution().first, m.ScaleClassResolution().second)},
      {"image format", std::string(ImageFormatName(m.image_format))},
      {"params hash", fmt::format("{:016x}", m.ParamsHash())},
      {"catalog hash", fmt::format("{:016x}", m.catalog_hash)}};
  for (const auto& [k, v] : rows) html += fmt::format("<tr><th>{}</th><td>{}</td></tr>", Escape(k), Escape(v));
  html += fmt::format("</table><details><summary>params</summary><pre>{}</pre></details></section>",
                      Escape(m.params.dump(2)));

  html += "<section id=\"metrics\"><h2>Proxy metrics</h2>";
  html += summary.target_row.empty()
              ? std::string("<p class=\"muted\">No Table-1 row to compare with (no target_row was given).</p>")
              : fmt::format("<p>Compared with the targets of Table-1 row <b>{}</b>.</p>", Escape(summary.target_row));
  html += "<table><tr><th>metric</th><th>measured (95% CI)</th><th>target</th><th>tolerance</th><th></th></tr>";
  for (const Metric metric : {Metric::kObjectsPerImage, Metric::kOcclusion, Metric::kSmall, Metric::kMedium,
                              Metric::kLarge}) {
    const Estimate e = optimizer::MetricOf(metrics, metric);
    std::string target = "<td></td><td></td><td></td>";
    for (const optimizer::Comparison& c : comparisons) {
      if (c.metric != metric) continue;
      target = fmt::format("<td class=\"num\">{}</td><td class=\"num\">±{}</td><td class=\"{}\">{}</td>",
                           Format(metric, c.reference.mean), Format(metric, c.tolerance), c.agrees ? "ok" : "bad",
                           c.agrees ? "met" : "missed");
    }
    html += fmt::format("<tr><td>{}</td><td class=\"num\">{} ± {}</td>{}</tr>", optimizer::MetricName(metric),
                        Format(metric, e.mean), Format(metric, e.ci95), target);
  }
  const auto [class_width, class_height] = m.ScaleClassResolution();
  html += fmt::format("</table><p class=\"muted\">{} images, {} of {} instances visible; scale classes counted at "
                      "{}x{}.</p></section>",
                      metrics.images, metrics.visible_instances, stats.instances, class_width, class_height);

  std::vector<std::string> occ_labels;
  for (int i = 0; i < kOcclusionBins; ++i) occ_labels.push_back(fmt::format("{}", i * 100 / kOcclusionBins));
  std::vector<std::string> object_labels;
  for (size_t i = 0; i < stats.objects.size(); ++i) object_labels.push_back(std::to_string(i));
  if (stats.objects.empty()) {
    stats.objects = {0};
    object_labels = {"0"};
  }
  html += "<section id=\"distributions\"><h2>Distributions</h2><div class=\"plots\">";
  html += BarChart("Occlusion of visible objects", "occlusion (%, bin start)", occ_labels,
                   {stats.occlusion.begin(), stats.occlusion.end()});
  html += BarChart(fmt::format("Scale classes (visible area at {}x{})", class_width, class_height), "COCO scale class", {"small", "medium", "large"},
                   {stats.scale.begin(), stats.scale.end()});
  html += BarChart("Visible objects per image", "objects", object_labels, stats.objects);
  html += "</div></section><section id=\"viewpoints\"><h2>Viewpoints</h2>" + HeatMap(stats) + "</section>";

  html += "<section id=\"samples\"><h2>Samples</h2><div class=\"grid\">";
  const size_t n = std::min(stats.image_ids.size(), static_cast<size_t>(options.samples));
  for (size_t k = 0; k < n; ++k) {
    const int64_t id = stats.image_ids[k * stats.image_ids.size() / n];
    SOLID_ASSIGN_OR_RETURN(std::string card, SampleCard(dataset, id, options.query_models));
    html += card;
    ++summary.samples;
  }
  html += "</div></section></main></body></html>\n";
  SOLID_RETURN_IF_ERROR(files::WriteFileAtomically(
      options.out, std::span(reinterpret_cast<const uint8_t*>(html.data()), html.size())));
  summary.bytes = static_cast<int64_t>(html.size());
  return summary;
}

}  // namespace solid::exporters
