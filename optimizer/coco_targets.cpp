#include "solid/optimizer/coco_targets.h"

#include <fmt/format.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <fstream>
#include <iterator>
#include <limits>
#include <optional>
#include <string>
#include <utility>

#include "solid/formats/records.h"

namespace solid::optimizer {
namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;

constexpr size_t kChunkBytes = size_t{1} << 20;
// For the second read that finds the line of a syntax error: no values are marked then.
constexpr uint64_t kUnlimited = std::numeric_limits<uint64_t>::max();

// The input in chunks of at most kChunkBytes, from a file or from text in memory, so that
// both take one path, and a token (a string or number nlohmann buffers whole) that grows
// past max_token_bytes is stopped at the next chunk instead of filling memory.
class Source {
 public:
  Source(std::string_view text, uint64_t max_token_bytes) : text_(text), max_token_bytes_(max_token_bytes) {}
  Source(std::ifstream* file, uint64_t max_token_bytes)
      : file_(file), buffer_(kChunkBytes), max_token_bytes_(max_token_bytes) {}

  bool AtEnd() { return pos_ == end_ && !Refill(); }
  const char& Current() const { return *pos_; }
  void Advance() { ++pos_; }
  uint64_t Offset() const { return base_ + static_cast<uint64_t>(pos_ - begin_); }
  // The parser has just reported a value or a key.
  void MarkValue() { last_value_ = Offset(); }
  // An I/O error or a broken limit, which the parser saw as the end of the input.
  const std::optional<Status>& failure() const { return failure_; }

 private:
  bool Refill() {
    if (failure_) return false;
    if (Offset() - last_value_ > max_token_bytes_) {
      failure_ = LimitExceededError(fmt::format(
          "byte {}: more than the limit of {} bytes before the next value ends (a string or number that long)",
          last_value_, max_token_bytes_));
      return false;
    }
    base_ = Offset();
    if (file_ == nullptr) {
      const size_t n = std::min(kChunkBytes, text_.size() - base_);
      begin_ = pos_ = text_.data() + base_;
      end_ = begin_ + n;
      return n > 0;
    }
    file_->read(buffer_.data(), static_cast<std::streamsize>(buffer_.size()));
    if (file_->bad()) {
      failure_ = IoError(fmt::format("byte {}: read failed: {}", base_, std::strerror(errno)));
      return false;
    }
    begin_ = pos_ = buffer_.data();
    end_ = begin_ + file_->gcount();
    return end_ != begin_;
  }

  std::string_view text_;
  std::ifstream* file_ = nullptr;
  std::vector<char> buffer_;
  const char* begin_ = nullptr;
  const char* pos_ = nullptr;
  const char* end_ = nullptr;
  uint64_t base_ = 0;  // offset of begin_
  uint64_t last_value_ = 0;
  uint64_t max_token_bytes_;
  std::optional<Status> failure_;
};

// What nlohmann's iterator input adapter needs (*, ++, ==) over a Source; the
// default-constructed iterator is the end.
class SourceIterator {
 public:
  using iterator_category = std::input_iterator_tag;
  using value_type = char;
  using difference_type = std::ptrdiff_t;
  using pointer = const char*;
  using reference = const char&;

  SourceIterator() = default;
  explicit SourceIterator(Source* source) : source_(source) {}
  const char& operator*() const { return source_->Current(); }
  SourceIterator& operator++() {
    source_->Advance();
    return *this;
  }
  friend bool operator==(const SourceIterator& a, const SourceIterator& b) { return a.AtEnd() == b.AtEnd(); }

 private:
  bool AtEnd() const { return source_ == nullptr || source_->AtEnd(); }
  Source* source_ = nullptr;
};

struct LineColumn {
  uint64_t line = 1, column = 1;
};

LineColumn LineColumnAt(Source& source, uint64_t offset) {
  LineColumn at;
  for (uint64_t i = 0; i < offset && !source.AtEnd(); ++i, source.Advance()) {
    if (source.Current() == '\n') {
      ++at.line;
      at.column = 1;
    } else {
      ++at.column;
    }
  }
  return at;
}

// "[json.exception.parse_error.101] parse error at line 1, column 4: syntax error ..." ->
// "syntax error ...": the location is printed in our own format.
std::string NlohmannMessage(const json::exception& error) {
  std::string_view message = error.what();
  if (const size_t id_end = message.find("] "); id_end != std::string_view::npos) message.remove_prefix(id_end + 2);
  if (message.starts_with("parse error")) {
    if (const size_t colon = message.find(": "); colon != std::string_view::npos) message.remove_prefix(colon + 2);
  }
  return std::string(message);
}

// RFC 6901: "~" and "/" in a key are escaped.
void AppendPointerToken(std::string_view key, std::string* pointer) {
  pointer->push_back('/');
  for (char c : key) {
    if (c == '~') {
      pointer->append("~0");
    } else if (c == '/') {
      pointer->append("~1");
    } else {
      pointer->push_back(c);
    }
  }
}

enum class Kind { kNull, kBoolean, kInteger, kNumber, kString, kObject, kArray };

struct Value {
  Kind kind = Kind::kNull;
  int64_t integer = 0;  // kInteger
  double number = 0;    // kInteger and kNumber
  bool boolean = false;
};

std::string Describe(const Value& v) {
  switch (v.kind) {
    case Kind::kNull: return "null";
    case Kind::kBoolean: return v.boolean ? "true" : "false";
    case Kind::kInteger: return std::to_string(v.integer);
    case Kind::kNumber: return fmt::format("{}", v.number);
    case Kind::kString: return "a string";
    case Kind::kObject: return "an object";
    case Kind::kArray: return "an array";
  }
  return "?";
}

// Integers, and numbers with a zero fraction within int64 (some writers put 640.0).
std::optional<int64_t> AsInteger(const Value& v) {
  if (v.kind == Kind::kInteger) return v.integer;
  if (v.kind == Kind::kNumber && std::trunc(v.number) == v.number && std::abs(v.number) < 0x1p63) {
    return static_cast<int64_t>(v.number);
  }
  return std::nullopt;
}

struct Image {
  int64_t id = 0;
  int32_t width = 0, height = 0;
  uint32_t index = 0;        // in the images array
  uint32_t annotations = 0;  // non-crowd
};

// Annotations read before the images array has ended, resolved when it ends. They are a
// prefix of the annotations array, so their position is their index.
struct PendingAnnotation {
  int64_t image_id = 0;
  double area = 0;
};

// The SAX events of nlohmann's parser (its static interface: no virtual calls). Keeps the
// images' id and size, and each annotation's image, area and crowd flag; any other value,
// containers included, is read past.
class CocoHandler {
 public:
  using number_integer_t = json::number_integer_t;
  using number_unsigned_t = json::number_unsigned_t;
  using number_float_t = json::number_float_t;
  using string_t = json::string_t;
  using binary_t = json::binary_t;

  CocoHandler(Source* source, std::string_view name, const CocoMatchOptions& options)
      : source_(source), name_(name), options_(options) {}

  bool null() { return OnValue({Kind::kNull}); }
  bool boolean(bool b) { return OnValue({.kind = Kind::kBoolean, .boolean = b}); }
  bool number_integer(number_integer_t i) {
    return OnValue({.kind = Kind::kInteger, .integer = i, .number = static_cast<double>(i)});
  }
  bool number_unsigned(number_unsigned_t u) {
    if (u > static_cast<uint64_t>(INT64_MAX)) return OnValue({.kind = Kind::kNumber, .number = static_cast<double>(u)});
    return OnValue({.kind = Kind::kInteger, .integer = static_cast<int64_t>(u), .number = static_cast<double>(u)});
  }
  bool number_float(number_float_t x, const string_t& /*text*/) { return OnValue({.kind = Kind::kNumber, .number = x}); }
  bool string(string_t& /*s*/) { return OnValue({Kind::kString}); }
  bool binary(binary_t& /*b*/) { return OnValue({Kind::kString}); }  // not produced by the text parser
  bool start_object(size_t /*size*/) { return OnValue({Kind::kObject}); }
  bool start_array(size_t /*size*/) { return OnValue({Kind::kArray}); }
  bool end_object() { return Close(); }
  bool end_array() { return Close(); }

  bool key(string_t& key) {
    source_->MarkValue();
    if (skip_depth_ > 0) return true;
    frames_.back().key.swap(key);
    return true;
  }

  bool parse_error(size_t position, const std::string& /*last_token*/, const json::exception& error) {
    // `position` counts the bytes read, the offending one included.
    parse_error_offset_ = position > 0 ? position - 1 : 0;
    parse_error_ = NlohmannMessage(error);
    return false;
  }

  const std::optional<Status>& failure() const { return failure_; }
  const std::optional<std::string>& parse_error_message() const { return parse_error_; }
  uint64_t parse_error_offset() const { return parse_error_offset_; }

  // After a successful parse.
  Result<CocoMatch> Finish() const;

 private:
  enum class Place { kTop, kImages, kImage, kAnnotations, kAnnotation };
  // An open container that is read: the top-level object, the two arrays and their
  // elements. An object's key is that of the member being read, an array's index that of
  // the element being read.
  struct Frame {
    Place place;
    int64_t index = -1;
    std::string key;
  };
  // Which members of the image or annotation being read have been seen.
  enum Field : unsigned { kId = 1, kWidth = 2, kHeight = 4, kImageId = 8, kArea = 16, kIsCrowd = 32 };

  bool OnValue(const Value& v) {
    source_->MarkValue();
    const bool container = v.kind == Kind::kObject || v.kind == Kind::kArray;
    if (skip_depth_ > 0) return !container || Skip();
    if (frames_.empty()) {
      if (v.kind != Kind::kObject) {
        return Fail(StatusCode::kParseError, "",
                    fmt::format("not a COCO instances file: the top level is {}, not an object", Describe(v)));
      }
      return Open(Place::kTop);
    }
    Frame& frame = frames_.back();
    switch (frame.place) {
      case Place::kTop: return TopMember(v);
      case Place::kImages:
      case Place::kAnnotations: {
        ++frame.index;
        const bool images = frame.place == Place::kImages;
        if (v.kind != Kind::kObject) {
          return Fail(StatusCode::kParseError, Pointer(),
                      fmt::format("{} must be an object, not {}", images ? "an image" : "an annotation", Describe(v)));
        }
        seen_ = 0;
        image_ = {};
        annotation_ = {};
        crowd_ = false;
        return Open(images ? Place::kImage : Place::kAnnotation);
      }
      case Place::kImage: return ImageMember(v);
      case Place::kAnnotation: return AnnotationMember(v);
    }
    return true;
  }

  bool Close() {
    if (skip_depth_ > 0) {
      --skip_depth_;
      return true;
    }
    bool ok = true;
    switch (frames_.back().place) {
      case Place::kTop: ok = FinishTop(); break;
      case Place::kImages: ok = FinishImages(); break;
      case Place::kImage: ok = FinishImage(); break;
      case Place::kAnnotations: break;
      case Place::kAnnotation: ok = FinishAnnotation(); break;
    }
    frames_.pop_back();
    return ok;
  }

  bool Open(Place place) {
    if (!CheckDepth()) return false;
    frames_.push_back({place});
    return true;
  }

  // A container inside a value that is not read.
  bool Skip() {
    if (!CheckDepth()) return false;
    ++skip_depth_;
    return true;
  }

  bool CheckDepth() {
    if (static_cast<int64_t>(frames_.size()) + skip_depth_ < options_.max_depth) return true;
    return Fail(StatusCode::kLimitExceeded, Pointer(),
                fmt::format("nested deeper than the limit of {} levels (byte {})", options_.max_depth,
                            source_->Offset()));
  }

  bool TopMember(const Value& v) {
    const std::string& key = frames_.back().key;
    const bool images = key == "images";
    if (!images && key != "annotations") {
      return v.kind == Kind::kObject || v.kind == Kind::kArray ? Skip() : true;
    }
    bool& seen = images ? seen_images_ : seen_annotations_;
    if (seen) return Fail(StatusCode::kParseError, Pointer(), "given twice");
    seen = true;
    if (v.kind != Kind::kArray) {
      return Fail(StatusCode::kParseError, Pointer(),
                  fmt::format("not a COCO instances file: must be an array, not {}", Describe(v)));
    }
    return Open(images ? Place::kImages : Place::kAnnotations);
  }

  // Marks `field` seen; a repeated key would otherwise replace what was read silently.
  bool See(Field field) {
    if ((seen_ & field) == 0) {
      seen_ |= field;
      return true;
    }
    return Fail(StatusCode::kParseError, Pointer(), "given twice");
  }

  bool ImageMember(const Value& v) {
    const std::string& key = frames_.back().key;
    if (key == "id") {
      if (!See(kId)) return false;
      const std::optional<int64_t> id = AsInteger(v);
      if (!id) return Fail(StatusCode::kParseError, Pointer(), fmt::format("must be an integer, not {}", Describe(v)));
      image_.id = *id;
      return true;
    }
    if (key == "width" || key == "height") {
      const bool width = key == "width";
      if (!See(width ? kWidth : kHeight)) return false;
      const std::optional<int64_t> side = AsInteger(v);
      if (!side || *side < 1 || *side > INT32_MAX) {
        return Fail(StatusCode::kParseError, Pointer(),
                    fmt::format("must be an integer from 1 to {}, not {}", INT32_MAX, Describe(v)));
      }
      (width ? image_.width : image_.height) = static_cast<int32_t>(*side);
      return true;
    }
    return v.kind == Kind::kObject || v.kind == Kind::kArray ? Skip() : true;
  }

  bool AnnotationMember(const Value& v) {
    const std::string& key = frames_.back().key;
    if (key == "image_id") {
      if (!See(kImageId)) return false;
      const std::optional<int64_t> id = AsInteger(v);
      if (!id) return Fail(StatusCode::kParseError, Pointer(), fmt::format("must be an integer, not {}", Describe(v)));
      annotation_.image_id = *id;
      return true;
    }
    if (key == "area") {
      if (!See(kArea)) return false;
      if ((v.kind != Kind::kInteger && v.kind != Kind::kNumber) || !(v.number >= 0)) {
        return Fail(StatusCode::kParseError, Pointer(), fmt::format("must be a number >= 0, not {}", Describe(v)));
      }
      annotation_.area = v.number;
      return true;
    }
    if (key == "iscrowd") {
      if (!See(kIsCrowd)) return false;
      const std::optional<int64_t> flag = v.kind == Kind::kBoolean ? std::optional<int64_t>(v.boolean) : AsInteger(v);
      if (!flag || (*flag != 0 && *flag != 1)) {
        return Fail(StatusCode::kParseError, Pointer(), fmt::format("must be 0, 1, true or false, not {}", Describe(v)));
      }
      crowd_ = *flag == 1;
      return true;
    }
    return v.kind == Kind::kObject || v.kind == Kind::kArray ? Skip() : true;
  }

  bool FinishImage() {
    constexpr std::pair<Field, std::string_view> kRequired[] = {{kId, "id"}, {kWidth, "width"}, {kHeight, "height"}};
    for (const auto& [field, name] : kRequired) {
      if ((seen_ & field) == 0) {
        return Fail(StatusCode::kParseError, Pointer(frames_.size() - 1),
                    fmt::format("an image without \"{}\" (images need id, width and height)", name));
      }
    }
    if (static_cast<int64_t>(images_.size()) >= options_.max_images) {
      return Fail(StatusCode::kLimitExceeded, Pointer(frames_.size() - 1),
                  fmt::format("more than the limit of {} images", options_.max_images));
    }
    image_.index = static_cast<uint32_t>(frames_[frames_.size() - 2].index);
    images_.push_back(image_);
    return true;
  }

  bool FinishAnnotation() {
    const int64_t index = frames_[frames_.size() - 2].index;
    if ((seen_ & kImageId) == 0) {
      return Fail(StatusCode::kParseError, Pointer(frames_.size() - 1), "an annotation without \"image_id\"");
    }
    if ((seen_ & kArea) == 0 && !crowd_) {
      return Fail(StatusCode::kParseError, Pointer(frames_.size() - 1),
                  "an annotation without \"area\" (needed unless iscrowd is 1)");
    }
    if (index >= options_.max_annotations) {
      return Fail(StatusCode::kLimitExceeded, Pointer(frames_.size() - 1),
                  fmt::format("more than the limit of {} annotations", options_.max_annotations));
    }
    ++annotations_;
    if (images_done_) return Resolve(annotation_, crowd_, index);
    pending_.push_back(annotation_);
    pending_crowd_.push_back(crowd_);
    return true;
  }

  bool FinishImages() {
    std::sort(images_.begin(), images_.end(), [](const Image& a, const Image& b) {
      return a.id != b.id ? a.id < b.id : a.index < b.index;
    });
    const auto same = std::adjacent_find(images_.begin(), images_.end(),
                                         [](const Image& a, const Image& b) { return a.id == b.id; });
    if (same != images_.end()) {
      return Fail(StatusCode::kCorrupt, fmt::format("/images/{}/id", same[1].index),
                  fmt::format("image id {} is also that of /images/{}", same->id, same->index));
    }
    images_done_ = true;
    for (size_t i = 0; i < pending_.size(); ++i) {
      if (!Resolve(pending_[i], pending_crowd_[i], static_cast<int64_t>(i))) return false;
    }
    pending_ = {};
    pending_crowd_ = {};
    return true;
  }

  bool FinishTop() {
    const std::pair<bool, std::string_view> arrays[] = {{seen_images_, "images"}, {seen_annotations_, "annotations"}};
    for (const auto& [seen, name] : arrays) {
      if (!seen) {
        return Fail(StatusCode::kParseError, "",
                    fmt::format("not a COCO instances file: no \"{}\" array at the top level", name));
      }
    }
    return true;
  }

  // Counts the annotation for its image and classes its area at the options' resolution.
  bool Resolve(const PendingAnnotation& a, bool crowd, int64_t index) {
    const auto image = std::lower_bound(images_.begin(), images_.end(), a.image_id,
                                        [](const Image& i, int64_t id) { return i.id < id; });
    if (image == images_.end() || image->id != a.image_id) {
      return Fail(StatusCode::kCorrupt, fmt::format("/annotations/{}/image_id", index),
                  fmt::format("image {} is not among the images", a.image_id));
    }
    if (crowd) {
      ++crowd_skipped_;
      return true;
    }
    ++image->annotations;
    // The ratio as the evaluations form it (optimize.cpp), so that areas exported from a
    // dataset class as its own metrics do.
    const double area_scale = static_cast<double>(options_.width) * options_.height /
                              (static_cast<double>(image->width) * image->height);
    const double scaled = std::min(a.area * area_scale, 0x1p62);  // far above 96^2: large either way
    accumulator_.AddVisibleInstance(static_cast<uint64_t>(std::llround(scaled)), /*full_area=*/0);
    return true;
  }

  // The JSON Pointer of the value being read, or with `frames` < frames_.size(), of an
  // enclosing container.
  std::string Pointer(size_t frames) const {
    std::string pointer;
    for (size_t i = 0; i < frames; ++i) {
      const Frame& f = frames_[i];
      if (f.place == Place::kImages || f.place == Place::kAnnotations) {
        pointer.push_back('/');
        pointer.append(std::to_string(f.index));
      } else {
        AppendPointerToken(f.key, &pointer);
      }
    }
    return pointer;
  }
  std::string Pointer() const { return Pointer(frames_.size()); }

  bool Fail(StatusCode code, std::string_view pointer, std::string_view message) {
    failure_ = Status(code, pointer.empty() ? fmt::format("{}: {}", name_, message)
                                            : fmt::format("{}: {}: {}", name_, pointer, message));
    return false;
  }

  Source* source_;
  std::string_view name_;
  const CocoMatchOptions& options_;
  std::vector<Frame> frames_;
  int64_t skip_depth_ = 0;
  bool seen_images_ = false, seen_annotations_ = false, images_done_ = false;

  unsigned seen_ = 0;
  Image image_;
  PendingAnnotation annotation_;
  bool crowd_ = false;

  std::vector<Image> images_;  // sorted by id once the images array has ended
  std::vector<PendingAnnotation> pending_;
  std::vector<bool> pending_crowd_;
  int64_t annotations_ = 0, crowd_skipped_ = 0;
  // Shares only: areas come in already scaled (each image has its own ratio), and image
  // counts are added in Finish, once every annotation is known.
  MetricsAccumulator accumulator_;

  std::optional<Status> failure_;
  std::optional<std::string> parse_error_;
  uint64_t parse_error_offset_ = 0;
};

Result<CocoMatch> CocoHandler::Finish() const {
  if (annotations_ == 0) return CorruptError(fmt::format("{}: /annotations: no annotations", name_));
  if (annotations_ == crowd_skipped_) {
    return CorruptError(fmt::format("{}: /annotations: all {} annotations are crowd (iscrowd 1), no object to count",
                                    name_, annotations_));
  }
  CocoMatch match;
  match.width = options_.width;
  match.height = options_.height;
  match.images = static_cast<int64_t>(images_.size());
  match.annotations = annotations_ - crowd_skipped_;
  match.crowd_skipped = crowd_skipped_;
  MetricsAccumulator accumulator = accumulator_;
  for (const Image& image : images_) {
    if (image.annotations == 0) {
      ++match.empty_images;
      if (options_.skip_empty_images) continue;
    }
    ++match.images_counted;
    accumulator.AddImageCounts(image.annotations, image.annotations);
  }
  const ProxyMetrics metrics = accumulator.Finish();
  match.objects_per_image = metrics.objects_per_image;
  match.small = metrics.small;
  match.medium = metrics.medium;
  match.large = metrics.large;
  for (Metric m : {Metric::kObjectsPerImage, Metric::kSmall, Metric::kMedium, Metric::kLarge}) {
    match.targets.push_back({m, MetricOf(metrics, m).mean, DefaultTolerance(m)});
  }
  return match;
}

Status CheckOptions(const CocoMatchOptions& options) {
  if (options.width < 1 || options.height < 1) {
    return InvalidArgumentError(
        fmt::format("the scale-class resolution must be at least 1x1, not {}x{}", options.width, options.height));
  }
  // Image indices and per-image counts are stored in 32 bits.
  if (options.max_images > UINT32_MAX || options.max_annotations > UINT32_MAX) {
    return InvalidArgumentError(fmt::format("max_images and max_annotations must be at most {}", UINT32_MAX));
  }
  return Status::Ok();
}

// `restart` gives a fresh Source over the same input, for the line of a syntax error.
template <typename Restart>
Result<CocoMatch> Match(Source* source, Restart restart, std::string_view name, const CocoMatchOptions& options) {
  CocoHandler handler(source, name, options);
  bool parsed = false;
  try {
    parsed = json::sax_parse(SourceIterator(source), SourceIterator(), &handler);
  } catch (const json::exception& error) {
    return InternalError(fmt::format("{}: JSON parser failed: {}", name, error.what()));
  }
  if (handler.failure()) return *handler.failure();
  if (source->failure()) return source->failure()->WithContext(name);
  if (!parsed) {
    if (!handler.parse_error_message()) return InternalError(fmt::format("{}: JSON parser stopped without saying why", name));
    const uint64_t offset = handler.parse_error_offset();
    Result<Source> fresh = restart();
    const std::string where = [&] {
      if (!fresh.ok()) return fmt::format("{}: byte {}", name, offset);
      const LineColumn at = LineColumnAt(*fresh, offset);
      return fmt::format("{}:{}:{}", name, at.line, at.column);
    }();
    return ParseError(fmt::format("{}: not JSON: {} (byte offset {})", where, *handler.parse_error_message(), offset));
  }
  return handler.Finish();
}

}  // namespace

nlohmann::json CocoMatch::ToJson() const {
  json rows = json::array();
  for (const Target& t : targets) {
    const bool count = t.metric == Metric::kObjectsPerImage;
    const Estimate& e = count                          ? objects_per_image
                        : t.metric == Metric::kSmall  ? small
                        : t.metric == Metric::kMedium ? medium
                                                      : large;
    rows.push_back({{"metric", MetricName(t.metric)},
                    {"value", t.value},
                    {"tolerance", t.tolerance},
                    {"ci95", e.ci95},
                    {"n", count ? images_counted : annotations}});
  }
  return {{"resolution", {width, height}},
          {"images", images},
          {"images_counted", images_counted},
          {"empty_images", empty_images},
          {"annotations", annotations},
          {"crowd_skipped", crowd_skipped},
          {"targets", std::move(rows)}};
}

Result<CocoMatch> TargetsFromCoco(const fs::path& annotations, const CocoMatchOptions& options) {
  SOLID_RETURN_IF_ERROR(CheckOptions(options));
  const std::string name = annotations.string();
  std::error_code ec;
  const fs::file_status status = fs::status(annotations, ec);
  if (status.type() == fs::file_type::not_found) return NotFoundError(fmt::format("{}: no such file", name));
  if (ec) return IoError(fmt::format("{}: {}", name, ec.message()));
  if (!fs::is_regular_file(status)) return IoError(fmt::format("{}: not a regular file", name));
  const uintmax_t size = fs::file_size(annotations, ec);
  if (ec) return IoError(fmt::format("{}: {}", name, ec.message()));
  if (size > options.max_file_bytes) {
    return LimitExceededError(
        fmt::format("{}: {} bytes is more than the limit of {} bytes", name, size, options.max_file_bytes));
  }
  std::ifstream file(annotations, std::ios::binary);
  if (!file) return IoError(fmt::format("{}: cannot open: {}", name, std::strerror(errno)));
  Source source(&file, options.max_token_bytes);
  std::ifstream again;
  auto restart = [&]() -> Result<Source> {
    again.open(annotations, std::ios::binary);
    if (!again) return IoError(fmt::format("{}: cannot reopen", name));
    return Source(&again, kUnlimited);
  };
  return Match(&source, restart, name, options);
}

Result<CocoMatch> TargetsFromCocoText(std::string_view text, std::string_view name, const CocoMatchOptions& options) {
  SOLID_RETURN_IF_ERROR(CheckOptions(options));
  if (text.size() > options.max_file_bytes) {
    return LimitExceededError(
        fmt::format("{}: {} bytes is more than the limit of {} bytes", name, text.size(), options.max_file_bytes));
  }
  Source source(text, options.max_token_bytes);
  auto restart = [&]() -> Result<Source> { return Source(text, kUnlimited); };
  return Match(&source, restart, name, options);
}

}  // namespace solid::optimizer
