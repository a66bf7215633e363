// Memory and speed of TargetsFromCoco (`solid optimize --match-coco`) on a large generated
// COCO instances file: writes the file (COCO train2017's shape by default: 118,287 images,
// about 7.3 annotations each, 1% crowd regions with uncompressed RLE, polygon
// segmentations, the keys and number formats pycocotools files have), derives the targets,
// and prints the file size, wall time, MB/s and the peak RSS (getrusage ru_maxrss) before
// and after the match. The file is removed afterwards. Not run by ctest: seconds to minutes.
//
//   coco_match_memory [--images 118287] [--out FILE] [--annotations-first] [--keep] [--seed 1]
//
// --annotations-first writes the annotations array before the images array, the order that
// makes TargetsFromCoco hold every annotation until the images are known.
#include <CLI/CLI.hpp>
#include <fmt/format.h>

#include <sys/resource.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <random>
#include <string>

#include "solid/optimizer/coco_targets.h"

namespace fs = std::filesystem;

namespace {

rusage Usage() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return usage;
}
double PeakRssMb() { return static_cast<double>(Usage().ru_maxrss) / 1024.0; }  // KiB on Linux

// "VmRSS" (now) or "VmHWM" (the peak since the last ResetPeakRss) of /proc/self/status, in MB.
double ProcStatusMb(std::string_view field) {
  std::ifstream in("/proc/self/status");
  std::string line;
  while (std::getline(in, line)) {
    if (line.starts_with(field)) return std::stod(line.substr(field.size() + 1)) / 1024.0;
  }
  return -1;
}

// The process's peak RSS (ru_maxrss) is mostly the libraries solid::optimizer links, mapped
// at start; resetting the kernel's high-water mark (clear_refs 5, Linux 4.0) lets the
// match's own peak be read above the RSS it started from.
bool ResetPeakRss() { return static_cast<bool>(std::ofstream("/proc/self/clear_refs") << "5"); }
double CpuSeconds() {
  const rusage u = Usage();
  return static_cast<double>(u.ru_utime.tv_sec + u.ru_stime.tv_sec) + (u.ru_utime.tv_usec + u.ru_stime.tv_usec) / 1e6;
}

std::string LoadAverage() {
  std::ifstream in("/proc/loadavg");
  std::string one, five, fifteen;
  in >> one >> five >> fifteen;
  return fmt::format("{} {} {}", one, five, fifteen);
}

// COCO's commonest image sizes.
constexpr std::pair<int, int> kSizes[] = {{640, 480}, {480, 640}, {640, 427}, {427, 640}, {640, 426},
                                          {500, 375}, {640, 360}, {375, 500}, {612, 612}, {640, 640}};

// Everything about image i comes from its own generator, so the two arrays can be written
// in either order from the same numbers.
std::mt19937_64 ImageRng(uint64_t seed, int64_t image) { return std::mt19937_64(seed * 0x9E3779B97F4A7C15ull + image); }

struct ImageShape {
  int width, height, annotations;
};

ImageShape ShapeOf(std::mt19937_64& rng) {
  const auto [w, h] = kSizes[rng() % std::size(kSizes)];
  // About 1% of COCO's images have no annotation; the rest average about 7.4 (geometric).
  const int n = rng() % 100 == 0 ? 0 : 1 + static_cast<int>(std::geometric_distribution<int>(1.0 / 7.4)(rng));
  return {w, h, std::min(n, 90)};
}

class Writer {
 public:
  explicit Writer(const fs::path& path) : file_(std::fopen(path.c_str(), "wb")) {}
  ~Writer() {
    if (file_ != nullptr) std::fclose(file_);
  }
  bool ok() const { return file_ != nullptr; }
  void Put(std::string_view s) {
    buffer_.append(s);
    if (buffer_.size() > (1u << 20)) Flush();
  }
  std::string& buffer() { return buffer_; }
  bool Close() {
    Flush();
    const bool ok = std::ferror(file_) == 0 && std::fclose(file_) == 0;
    file_ = nullptr;
    return ok;
  }

 private:
  void Flush() {
    std::fwrite(buffer_.data(), 1, buffer_.size(), file_);
    buffer_.clear();
  }
  std::FILE* file_;
  std::string buffer_;
};

void WriteImage(Writer& out, int64_t id, const ImageShape& s, bool first) {
  out.Put(fmt::format("{}{{\"license\":{},\"file_name\":\"{:012}.jpg\",\"coco_url\":\"http://images.cocodataset.org/"
                      "train2017/{:012}.jpg\",\"height\":{},\"width\":{},\"date_captured\":\"2013-11-14 11:18:45\","
                      "\"flickr_url\":\"http://farm9.staticflickr.com/8186/{}_4e622c8349_z.jpg\",\"id\":{}}}",
                      first ? "" : ",", 1 + id % 8, id, id, s.height, s.width, 8119368305 + id, id));
}

void WriteAnnotations(Writer& out, std::mt19937_64& rng, int64_t image, const ImageShape& s, int64_t* next_id) {
  std::uniform_real_distribution<double> unit(0, 1);
  for (int k = 0; k < s.annotations; ++k) {
    // Areas log-uniform from 16 px to about half the image: COCO's spread of sizes.
    const double image_area = static_cast<double>(s.width) * s.height;
    const double area = std::exp(std::log(16.0) + unit(rng) * (std::log(image_area / 2) - std::log(16.0)));
    const double r = std::sqrt(area / std::numbers::pi);
    const double cx = r + unit(rng) * std::max(1.0, s.width - 2 * r), cy = r + unit(rng) * std::max(1.0, s.height - 2 * r);
    const bool crowd = rng() % 100 == 0;
    std::string& b = out.buffer();
    b.append(*next_id == 1 ? "{\"segmentation\":" : ",{\"segmentation\":");
    if (crowd) {
      // Uncompressed RLE, as COCO stores crowd regions: runs down the columns.
      fmt::format_to(std::back_inserter(b), "{{\"counts\":[");
      const int runs = 2 * static_cast<int>(std::min(2.0 * r, 200.0));
      for (int i = 0; i < runs; ++i) fmt::format_to(std::back_inserter(b), "{}{}", i ? "," : "", 1 + rng() % 400);
      fmt::format_to(std::back_inserter(b), "],\"size\":[{},{}]}}", s.height, s.width);
    } else {
      // One polygon (sometimes two) around the centre with COCO's two decimals; more
      // corners for larger objects, as annotators drew them.
      const int polygons = rng() % 8 == 0 ? 2 : 1;
      const int corners = std::clamp(static_cast<int>(6 + std::sqrt(area) / 4), 6, 100);
      b.push_back('[');
      for (int p = 0; p < polygons; ++p) {
        b.append(p ? ",[" : "[");
        for (int i = 0; i < corners; ++i) {
          const double t = 2 * std::numbers::pi * i / corners, jitter = 0.8 + 0.4 * unit(rng);
          fmt::format_to(std::back_inserter(b), "{}{:.2f},{:.2f}", i ? "," : "", cx + jitter * r * std::cos(t),
                         cy + jitter * r * std::sin(t));
        }
        b.push_back(']');
      }
      b.push_back(']');
    }
    fmt::format_to(std::back_inserter(b),
                   ",\"area\":{:.4f},\"iscrowd\":{},\"image_id\":{},\"bbox\":[{:.2f},{:.2f},{:.2f},{:.2f}],"
                   "\"category_id\":{},\"id\":{}}}",
                   area, crowd ? 1 : 0, image, cx - r, cy - r, 2 * r, 2 * r, 1 + rng() % 90, *next_id);
    ++*next_id;
    out.Put("");
  }
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"Peak memory and speed of TargetsFromCoco on a large generated COCO instances file"};
  int64_t images = 118287;
  std::string out = (fs::temp_directory_path() / "solid-coco-match-memory.json").string();
  bool annotations_first = false, keep = false;
  uint64_t seed = 1;
  app.add_option("--images", images, "Images in the generated file")->capture_default_str()->check(CLI::PositiveNumber);
  app.add_option("--out", out, "Where the file is written")->capture_default_str();
  app.add_flag("--annotations-first", annotations_first, "Write the annotations array before the images array");
  app.add_flag("--keep", keep, "Keep the file afterwards");
  app.add_option("--seed", seed, "Generator seed")->capture_default_str();
  CLI11_PARSE(app, argc, argv);
  // The libraries solid::optimizer links (the renderer's among them) make up most of this.
  const double rss_at_start = PeakRssMb();

  const auto t0 = std::chrono::steady_clock::now();
  int64_t annotations = 0;
  {
    Writer w(out);
    if (!w.ok()) {
      fmt::print(stderr, "{}: cannot write\n", out);
      return 1;
    }
    w.Put(R"({"info":{"description":"generated by bench/coco_match_memory","version":"1.0","year":2026},)"
          R"("licenses":[{"url":"http://creativecommons.org/licenses/by-nc-sa/2.0/","id":1,"name":"x"}],)");
    auto write_images = [&] {
      w.Put("\"images\":[");
      for (int64_t i = 1; i <= images; ++i) {
        std::mt19937_64 rng = ImageRng(seed, i);
        WriteImage(w, i, ShapeOf(rng), i == 1);
      }
      w.Put("]");
    };
    auto write_annotations = [&] {
      w.Put("\"annotations\":[");
      int64_t next_id = 1;
      for (int64_t i = 1; i <= images; ++i) {
        std::mt19937_64 rng = ImageRng(seed, i);
        const ImageShape s = ShapeOf(rng);
        WriteAnnotations(w, rng, i, s, &next_id);
      }
      annotations = next_id - 1;
      w.Put("]");
    };
    if (annotations_first) {
      write_annotations();
      w.Put(",");
      write_images();
    } else {
      write_images();
      w.Put(",");
      write_annotations();
    }
    w.Put(R"(,"categories":[{"supercategory":"person","id":1,"name":"person"}]})");
    if (!w.Close()) {
      fmt::print(stderr, "{}: write failed\n", out);
      return 1;
    }
  }
  const double generate_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const double file_mb = static_cast<double>(fs::file_size(out)) / 1e6;
  const double rss_before = PeakRssMb();
  const double current_before = ProcStatusMb("VmRSS:");
  const bool reset = ResetPeakRss();

  const auto t1 = std::chrono::steady_clock::now();
  const double cpu1 = CpuSeconds();
  auto match = solid::optimizer::TargetsFromCoco(out, {});
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t1).count();
  const double cpu_seconds = CpuSeconds() - cpu1;
  const double rss_after = PeakRssMb();
  const double hwm_after = ProcStatusMb("VmHWM:");
  if (!keep) fs::remove(out);
  if (!match.ok()) {
    fmt::print(stderr, "{}\n", match.status().ToString());
    return 1;
  }

  fmt::print("file: {:.1f} MB ({} images, {} annotations, {} first; generated in {:.1f} s)\n", file_mb, images,
             annotations, annotations_first ? "annotations" : "images", generate_seconds);
  fmt::print("TargetsFromCoco: {:.2f} s wall, {:.0f} MB/s ({:.2f} s of CPU, {:.0f} MB/s)\n", seconds, file_mb / seconds,
             cpu_seconds, file_mb / cpu_seconds);
  fmt::print("peak RSS (ru_maxrss): {:.1f} MB at the start, {:.1f} MB before the match, {:.1f} MB after\n", rss_at_start,
             rss_before, rss_after);
  if (reset) {
    fmt::print("the match: RSS {:.1f} MB before, peak {:.1f} MB during: {:.1f} MB more ({:.4f} of the file size)\n",
               current_before, hwm_after, hwm_after - current_before, (hwm_after - current_before) / file_mb);
  }
  fmt::print("load average (1, 5, 15 min): {}\n", LoadAverage());
  fmt::print("targets: {}\n", match->ToJson().dump());
  return 0;
}
