// OBJ and MTL readers, written by hand rather than on tinyobjloader: that library cannot
// name "file:line:column" in its errors, has no input limits, and reads a malformed number
// (nan included) as a default or a prefix without an error; docs "input-formats" section 4
// and style H3/H8 require all three.
// Lines are scanned as string_views into the input; only '\'-continued lines are copied.

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstring>
#include <iterator>
#include <numbers>
#include <string>
#include <string_view>
#include <unordered_set>
#include <vector>

#include <fmt/format.h>

#include "obj.h"

namespace solid::convert {
namespace {

bool IsBlank(char c) { return c == ' ' || c == '\t'; }

std::string_view TrimBlanks(std::string_view s) {
  while (!s.empty() && IsBlank(s.front())) s.remove_prefix(1);
  while (!s.empty() && IsBlank(s.back())) s.remove_suffix(1);
  return s;
}

bool EqualsIgnoreCase(std::string_view a, std::string_view b) {
  if (a.size() != b.size()) return false;
  for (size_t i = 0; i < a.size(); ++i) {
    char x = a[i], y = b[i];
    if (x >= 'A' && x <= 'Z') x = static_cast<char>(x - 'A' + 'a');
    if (y >= 'A' && y <= 'Z') y = static_cast<char>(y - 'A' + 'a');
    if (x != y) return false;
  }
  return true;
}

bool EndsWithIgnoreCase(std::string_view s, std::string_view suffix) {
  return s.size() >= suffix.size() && EqualsIgnoreCase(s.substr(s.size() - suffix.size()), suffix);
}

// Input text quoted in messages is cut, so a fuzzed megabyte token cannot flood a log.
std::string Quote(std::string_view s) {
  constexpr size_t kMaxQuoted = 40;
  std::string out = "'";
  for (char c : s.substr(0, kMaxQuoted)) out += (static_cast<unsigned char>(c) < 0x20) ? '?' : c;
  out += s.size() > kMaxQuoted ? "...'" : "'";
  return out;
}

// Both readers check the input size and encoding before scanning any line.
Status CheckInput(std::span<const uint8_t> bytes, std::string_view name, const ObjReadOptions& options) {
  if (bytes.size() > options.max_bytes) {
    return LimitExceededError(fmt::format("{}: {} bytes exceed max_bytes ({})", name, bytes.size(), options.max_bytes));
  }
  if (bytes.size() >= 2 && ((bytes[0] == 0xFE && bytes[1] == 0xFF) || (bytes[0] == 0xFF && bytes[1] == 0xFE))) {
    return ParseError(fmt::format("{}:1:1: UTF-16 text is not supported (convert the file to UTF-8)", name));
  }
  return Status::Ok();
}

// Splits input into logical lines (LF, CRLF or lone CR), optionally joining lines that end in
// '\', and turns pointers into "name:line:column" for messages.
class LineReader {
 public:
  LineReader(std::span<const uint8_t> bytes, std::string_view name, uint64_t max_line_length,
             bool join_continuations)
      : begin_(reinterpret_cast<const char*>(bytes.data())),
        end_(begin_ + bytes.size()),
        pos_(begin_),
        name_(name),
        max_line_length_(max_line_length),
        join_continuations_(join_continuations) {
    if (bytes.size() >= 3 && std::memcmp(begin_, "\xEF\xBB\xBF", 3) == 0) pos_ += 3;
  }

  // Advances to the next logical line; false at the end of the input or on error (see status()).
  bool Next() {
    if (pos_ >= end_) return false;
    joined_.clear();
    segments_.clear();
    joining_ = false;
    while (true) {
      const char* start = pos_;
      const char* stop = FindLineEnd(start);
      pos_ = stop;
      if (pos_ < end_) pos_ += (*pos_ == '\r' && pos_ + 1 < end_ && pos_[1] == '\n') ? 2 : 1;
      const uint64_t physical_line = next_line_number_++;
      const auto length = static_cast<uint64_t>(stop - start);
      if (length > max_line_length_) {
        status_ = LimitExceededError(fmt::format("{}:{}:{}: line is longer than max_line_length ({} bytes)", name_,
                                                 physical_line, max_line_length_ + 1, max_line_length_));
        return false;
      }
      const bool continued = join_continuations_ && length > 0 && stop[-1] == '\\';
      if (!continued && !joining_) {
        line_ = std::string_view(start, length);
        line_number_ = physical_line;
        return true;
      }
      if (!joining_) line_number_ = physical_line;
      joining_ = true;
      segments_.push_back({joined_.size(), physical_line});
      joined_.append(start, length);
      if (continued) joined_.back() = ' ';
      if (joined_.size() > max_line_length_) {
        status_ = LimitExceededError(
            fmt::format("{}:{}:{}: line joined by '\\' continuations is longer than max_line_length ({} bytes)",
                        name_, physical_line, length, max_line_length_));
        return false;
      }
      if (!continued || pos_ >= end_) {
        line_ = joined_;
        return true;
      }
    }
  }

  std::string_view line() const { return line_; }
  uint64_t line_number() const { return line_number_; }
  const Status& status() const { return status_; }

  // "name:line:column" of a character of line() (or one past its end).
  std::string Where(const char* p) const {
    auto offset = static_cast<uint64_t>(p - line_.data());
    if (!joining_) return fmt::format("{}:{}:{}", name_, line_number_, offset + 1);
    auto segment = std::prev(std::upper_bound(segments_.begin(), segments_.end(), offset,
                                              [](uint64_t o, const Segment& s) { return o < s.offset; }));
    return fmt::format("{}:{}:{}", name_, segment->line, offset - segment->offset + 1);
  }

 private:
  struct Segment {
    uint64_t offset;  // in joined_
    uint64_t line;
  };

  // memchr for both terminators, remembering each hit, so files with only CR (or only LF)
  // line ends are not rescanned from every line: linear overall.
  const char* FindLineEnd(const char* start) {
    if (next_lf_ < start) next_lf_ = Find(start, '\n');
    if (next_cr_ < start) next_cr_ = Find(start, '\r');
    return std::min(next_lf_, next_cr_);
  }
  const char* Find(const char* start, char c) const {
    const void* hit = std::memchr(start, c, static_cast<size_t>(end_ - start));
    return hit ? static_cast<const char*>(hit) : end_;
  }

  const char* begin_;
  const char* end_;
  const char* pos_;
  const char* next_lf_ = nullptr;
  const char* next_cr_ = nullptr;
  std::string_view name_;
  uint64_t max_line_length_;
  bool join_continuations_;
  uint64_t next_line_number_ = 1;
  std::string_view line_;
  uint64_t line_number_ = 0;
  bool joining_ = false;
  std::string joined_;
  std::vector<Segment> segments_;
  Status status_;
};

// Blank-separated tokens of one record.
class Tokens {
 public:
  explicit Tokens(std::string_view text) : p_(text.data()), end_(text.data() + text.size()) {}

  std::string_view Next() {
    while (p_ < end_ && IsBlank(*p_)) ++p_;
    const char* start = p_;
    while (p_ < end_ && !IsBlank(*p_)) ++p_;
    return {start, static_cast<size_t>(p_ - start)};
  }
  // Like Next(), but a token starting with '#' is a trailing comment that ends the record.
  std::string_view NextField() {
    std::string_view token = Next();
    if (!token.empty() && token.front() == '#') {
      p_ = end_;
      return {};
    }
    return token;
  }
  std::string_view Rest() const { return TrimBlanks({p_, static_cast<size_t>(end_ - p_)}); }
  const char* position() const { return p_; }

 private:
  const char* p_;
  const char* end_;
};

// Numbers follow std::from_chars (locale-independent, '.' only) plus a leading '+'.
enum class NumberError { kNone, kMalformed, kOutOfRange, kNonFinite };

NumberError ParseDouble(std::string_view token, double& value) {
  const char* first = token.data();
  const char* last = first + token.size();
  if (first < last && *first == '+') {
    ++first;
    if (first < last && (*first == '+' || *first == '-')) return NumberError::kMalformed;
  }
  auto [ptr, ec] = std::from_chars(first, last, value, std::chars_format::general);
  if (ec == std::errc::invalid_argument || ptr != last || first == last) return NumberError::kMalformed;
  if (ec == std::errc::result_out_of_range) return NumberError::kOutOfRange;
  if (!std::isfinite(value)) return NumberError::kNonFinite;
  return NumberError::kNone;
}

// Triangulates one polygon in the plane of its Newell normal. Scratch buffers are members so
// that a file of quads does not allocate per face.
class PolygonTriangulator {
 public:
  enum class Outcome { kConvexFan, kEarClipped, kConcaveFallbackFan, kDegenerateFan };

  // Appends 3 polygon-local corner indices per triangle to `triangles`, in the polygon's winding.
  Outcome Run(std::span<const std::array<double, 3>> corner_positions, std::vector<uint32_t>& triangles) {
    const size_t n = corner_positions.size();
    if (!Project(corner_positions)) {
      AppendFan(n, triangles);
      return Outcome::kDegenerateFan;
    }
    if (IsConvex()) {
      AppendFan(n, triangles);
      return Outcome::kConvexFan;
    }
    const size_t before = triangles.size();
    if (ClipEars(triangles)) return Outcome::kEarClipped;
    triangles.resize(before);
    AppendFan(n, triangles);
    return Outcome::kConcaveFallbackFan;
  }

 private:
  using Point = std::array<double, 2>;

  static double Cross(const Point& a, const Point& b, const Point& c) {
    return (b[0] - a[0]) * (c[1] - b[1]) - (b[1] - a[1]) * (c[0] - b[0]);
  }
  static void AppendFan(size_t n, std::vector<uint32_t>& triangles) {
    for (uint32_t i = 1; i + 1 < n; ++i) triangles.insert(triangles.end(), {0, i, i + 1});
  }

  // Normalises the corners into [-1, 1]^3 (so that products cannot overflow, whatever the
  // input magnitude), then drops the dominant axis of the Newell normal, ordering the other
  // two so that the polygon is counter-clockwise in 2D. False when there is no plane.
  bool Project(std::span<const std::array<double, 3>> p) {
    std::array<double, 3> lo = p[0], hi = p[0];
    for (const auto& q : p) {
      for (int k = 0; k < 3; ++k) {
        lo[k] = std::min(lo[k], q[k]);
        hi[k] = std::max(hi[k], q[k]);
      }
    }
    std::array<double, 3> center{};
    double half_extent = 0;
    for (int k = 0; k < 3; ++k) {
      center[k] = lo[k] * 0.5 + hi[k] * 0.5;
      half_extent = std::max(half_extent, hi[k] * 0.5 - lo[k] * 0.5);
    }
    if (!(half_extent > 0)) return false;
    unit_.resize(p.size());
    for (size_t i = 0; i < p.size(); ++i) {
      for (int k = 0; k < 3; ++k) unit_[i][k] = (p[i][k] * 0.5 - center[k] * 0.5) / half_extent;
    }
    std::array<double, 3> normal{};
    for (size_t i = 0; i < p.size(); ++i) {
      const auto& a = unit_[i];
      const auto& b = unit_[(i + 1) % p.size()];
      normal[0] += (a[1] - b[1]) * (a[2] + b[2]);
      normal[1] += (a[2] - b[2]) * (a[0] + b[0]);
      normal[2] += (a[0] - b[0]) * (a[1] + b[1]);
    }
    int axis = 0;
    for (int k = 1; k < 3; ++k) {
      if (std::abs(normal[k]) > std::abs(normal[axis])) axis = k;
    }
    if (!(std::abs(normal[axis]) > 1e-300)) return false;
    int u = (axis + 1) % 3, v = (axis + 2) % 3;
    if (normal[axis] < 0) std::swap(u, v);
    points_.resize(p.size());
    for (size_t i = 0; i < p.size(); ++i) points_[i] = {unit_[i][u], unit_[i][v]};
    return true;
  }

  // Convex: no clockwise turn, no reversal, and one full turn in total (a pentagram turns twice).
  bool IsConvex() const {
    const size_t n = points_.size();
    double turning = 0;
    for (size_t i = 0; i < n; ++i) {
      const Point& a = points_[(i + n - 1) % n];
      const Point& b = points_[i];
      const Point& c = points_[(i + 1) % n];
      const double e1x = b[0] - a[0], e1y = b[1] - a[1], e2x = c[0] - b[0], e2y = c[1] - b[1];
      const double cross = e1x * e2y - e1y * e2x;
      const double dot = e1x * e2x + e1y * e2y;
      const double tolerance = 1e-12 * std::sqrt((e1x * e1x + e1y * e1y) * (e2x * e2x + e2y * e2y));
      if (cross < -tolerance) return false;
      if (cross <= tolerance && dot < 0) return false;
      turning += std::atan2(std::max(cross, 0.0), dot);
    }
    return turning < 3 * std::numbers::pi;
  }

  bool Inside(const Point& a, const Point& b, const Point& c, const Point& r, bool strict) const {
    const double d1 = Cross(a, b, r), d2 = Cross(b, c, r), d3 = Cross(c, a, r);
    return strict ? (d1 > 0 && d2 > 0 && d3 > 0) : (d1 >= 0 && d2 >= 0 && d3 >= 0);
  }

  // Ear clipping over a linked ring. A first sweep clips only strictly convex ears containing
  // no other corner (boundary included); when a whole sweep finds none (collinear or repeated
  // corners), the second mode also clips flat corners and ignores corners on an ear's boundary.
  // Gives up on a sweep that finds nothing even then, or past a work budget (self-intersecting
  // input), so the caller fans instead: deterministic, and bounded for fuzzed 4096-gons.
  bool ClipEars(std::vector<uint32_t>& triangles) {
    const auto n = static_cast<uint32_t>(points_.size());
    prev_.resize(n);
    next_.resize(n);
    alive_.assign(n, 1);
    listed_.assign(n, 0);
    reflex_.clear();
    for (uint32_t i = 0; i < n; ++i) {
      prev_[i] = (i + n - 1) % n;
      next_[i] = (i + 1) % n;
    }
    for (uint32_t i = 0; i < n; ++i) NoteIfReflex(i);
    uint64_t work = 0;
    const uint64_t work_budget = uint64_t{16} * n * n + 1024;
    uint32_t remaining = n, i = 0, steps_without_clip = 0;
    bool relaxed = false;
    while (remaining > 3) {
      if (steps_without_clip > remaining) {
        if (relaxed) return false;
        relaxed = true;
        steps_without_clip = 0;
      }
      const uint32_t a = prev_[i], c = next_[i];
      const double turn = Cross(points_[a], points_[i], points_[c]);
      bool ear = turn > 0 || (relaxed && turn >= -1e-12);
      for (size_t k = 0; ear && k < reflex_.size(); ++k) {
        const uint32_t r = reflex_[k];
        if (!alive_[r] || r == a || r == i || r == c) continue;
        const Point& q = points_[r];
        if (q == points_[a] || q == points_[i] || q == points_[c]) continue;
        ear = !Inside(points_[a], points_[i], points_[c], q, relaxed);
      }
      work += reflex_.size() + 1;
      if (work > work_budget) return false;
      if (!ear) {
        i = c;
        ++steps_without_clip;
        continue;
      }
      triangles.insert(triangles.end(), {a, i, c});
      alive_[i] = 0;
      next_[a] = c;
      prev_[c] = a;
      --remaining;
      NoteIfReflex(a);
      NoteIfReflex(c);
      steps_without_clip = 0;
      i = c;
    }
    triangles.insert(triangles.end(), {prev_[i], i, next_[i]});
    return true;
  }

  // Only non-convex corners can lie inside an ear, so only they are tested; the list is
  // append-only and entries are re-checked for liveness when read.
  void NoteIfReflex(uint32_t i) {
    if (listed_[i]) return;
    if (Cross(points_[prev_[i]], points_[i], points_[next_[i]]) <= 0) {
      listed_[i] = 1;
      reflex_.push_back(i);
    }
  }

  std::vector<std::array<double, 3>> unit_;
  std::vector<Point> points_;
  std::vector<uint32_t> prev_, next_, reflex_;
  std::vector<uint8_t> alive_, listed_;
};

class ObjParser {
 public:
  ObjParser(std::span<const uint8_t> bytes, std::string_view name, const ObjReadOptions& options)
      : bytes_(bytes), name_(name), options_(options), lines_(bytes, name, options.max_line_length, true) {}

  Result<ObjData> Run() {
    SOLID_RETURN_IF_ERROR(CheckInput(bytes_, name_, options_));
    while (lines_.Next()) SOLID_RETURN_IF_ERROR(ParseRecord(lines_.line()));
    SOLID_RETURN_IF_ERROR(lines_.status());
    return std::move(data_);
  }

 private:
  std::string Where(const char* p) const { return lines_.Where(p); }
  std::string Where(std::string_view token) const { return lines_.Where(token.data()); }

  Status ParseRecord(std::string_view line) {
    Tokens tokens(line);
    const std::string_view keyword = tokens.Next();
    if (keyword.empty() || keyword.front() == '#') return Status::Ok();
    if (keyword == "v") return ParseVertexRecord(tokens, keyword);
    if (keyword == "vt") return ParseUvRecord(tokens, keyword);
    if (keyword == "vn") return ParseNormalRecord(tokens, keyword);
    if (keyword == "f") return ParseFace(tokens);
    if (keyword == "l") return CountLineOrPoint(data_.counts.line_records, &ObjFaceBlock::line_records);
    if (keyword == "p") return CountLineOrPoint(data_.counts.point_records, &ObjFaceBlock::point_records);
    if (keyword == "o") return SetState(object_, tokens.Rest());
    if (keyword == "g") return SetGroup(tokens);
    if (keyword == "usemtl") return SetState(material_, tokens.Rest());
    if (keyword == "mtllib") return AddMtllibs(tokens);
    if (keyword == "s") return Status::Ok();  // smoothing groups: normals come from vn
    ++data_.counts.unknown_records;
    return Status::Ok();
  }

  Status NumberStatus(NumberError error, std::string_view token, std::string_view record) const {
    switch (error) {
      case NumberError::kNone:
        return Status::Ok();
      case NumberError::kMalformed:
        return ParseError(fmt::format("{}: malformed number {} in '{}' record", Where(token), Quote(token), record));
      case NumberError::kOutOfRange:
        return ParseError(fmt::format("{}: number {} is out of double range", Where(token), Quote(token)));
      case NumberError::kNonFinite:
        return ParseError(fmt::format("{}: non-finite coordinate {}", Where(token), Quote(token)));
    }
    return Status::Ok();
  }

  // Reads `required` numbers into `values`, then checks and drops up to `extra` more.
  Status ReadNumbers(Tokens& tokens, std::string_view record, double* values, int required, int extra) {
    for (int i = 0; i < required + extra; ++i) {
      const std::string_view token = tokens.NextField();
      if (token.empty()) {
        if (i >= required) return Status::Ok();
        return ParseError(fmt::format("{}: '{}' record needs {} numbers, found {}", Where(tokens.position()), record,
                                      required, i));
      }
      double value = 0;
      SOLID_RETURN_IF_ERROR(NumberStatus(ParseDouble(token, value), token, record));
      if (i < required) values[i] = value;
    }
    return Status::Ok();
  }

  Status CheckVertexLimit(size_t count, std::string_view record) const {
    if (count < options_.max_vertices) return Status::Ok();
    return LimitExceededError(fmt::format("{}:{}:1: more than max_vertices ({}) '{}' records", name_,
                                          lines_.line_number(), options_.max_vertices, record));
  }

  Status ParseVertexRecord(Tokens& tokens, std::string_view record) {
    SOLID_RETURN_IF_ERROR(CheckVertexLimit(data_.positions.size(), record));
    std::array<double, 3> xyz{};
    // Up to 4 more numbers (w, or an r g b [a] colour extension) are validated and dropped.
    SOLID_RETURN_IF_ERROR(ReadNumbers(tokens, record, xyz.data(), 3, 4));
    SOLID_RETURN_IF_ERROR(RejectTrailing(tokens, record));
    data_.positions.push_back(xyz);
    return Status::Ok();
  }

  Status ParseUvRecord(Tokens& tokens, std::string_view record) {
    SOLID_RETURN_IF_ERROR(CheckVertexLimit(data_.uvs.size(), record));
    // u is required, v defaults to 0, w is checked and dropped; tokens after w are ignored.
    std::array<double, 2> uv{};
    SOLID_RETURN_IF_ERROR(ReadNumbers(tokens, record, uv.data(), 1, 0));
    double w = 0;
    for (double* value : {&uv[1], &w}) {
      const std::string_view token = tokens.NextField();
      if (token.empty()) break;
      SOLID_RETURN_IF_ERROR(NumberStatus(ParseDouble(token, *value), token, record));
    }
    data_.uvs.push_back(uv);
    return Status::Ok();
  }

  Status ParseNormalRecord(Tokens& tokens, std::string_view record) {
    SOLID_RETURN_IF_ERROR(CheckVertexLimit(data_.normals.size(), record));
    std::array<double, 3> xyz{};
    SOLID_RETURN_IF_ERROR(ReadNumbers(tokens, record, xyz.data(), 3, 0));
    SOLID_RETURN_IF_ERROR(RejectTrailing(tokens, record));
    data_.normals.push_back(xyz);
    return Status::Ok();
  }

  Status RejectTrailing(Tokens& tokens, std::string_view record) const {
    const std::string_view token = tokens.NextField();
    if (token.empty()) return Status::Ok();
    return ParseError(fmt::format("{}: unexpected {} after the numbers of a '{}' record", Where(token), Quote(token),
                                  record));
  }

  // 1-based or negative (relative to the `count` elements defined before this line).
  Status ResolveIndex(std::string_view digits, std::string_view corner, uint64_t count, const char* what,
                      int64_t& index) const {
    std::string_view number = digits;
    if (!number.empty() && number.front() == '+') number.remove_prefix(1);
    int64_t raw = 0;
    auto [ptr, ec] = std::from_chars(number.data(), number.data() + number.size(), raw);
    if (number.empty() || ec == std::errc::invalid_argument || ptr != number.data() + number.size()) {
      return ParseError(fmt::format("{}: malformed face corner {}", Where(corner), Quote(corner)));
    }
    const bool representable = ec != std::errc::result_out_of_range;
    if (representable && raw > 0 && static_cast<uint64_t>(raw) <= count) {
      index = raw - 1;
      return Status::Ok();
    }
    if (representable && raw < 0 && static_cast<uint64_t>(-(raw + 1)) < count) {
      index = static_cast<int64_t>(count) + raw;
      return Status::Ok();
    }
    return CorruptError(fmt::format("{}: index_out_of_range: {} index {} in corner {} ({} defined before this line)",
                                    Where(digits), what, Quote(digits), Quote(corner), count));
  }

  // "v", "v/t", "v//n", "v/t/n"; an empty t or n (as in "v/t/" or "v//") means absent.
  Status ParseCorner(std::string_view token, ObjCorner& corner) const {
    const size_t slash1 = token.find('/');
    const std::string_view v = token.substr(0, slash1);
    std::string_view t, n;
    if (slash1 != std::string_view::npos) {
      const std::string_view after = token.substr(slash1 + 1);
      const size_t slash2 = after.find('/');
      t = after.substr(0, slash2);
      if (slash2 != std::string_view::npos) {
        n = after.substr(slash2 + 1);
        if (n.find('/') != std::string_view::npos) {
          return ParseError(fmt::format("{}: face corner {} has more than 3 indices", Where(token), Quote(token)));
        }
      }
    }
    if (v.empty()) {
      return ParseError(fmt::format("{}: face corner {} has no vertex index", Where(token), Quote(token)));
    }
    corner = ObjCorner{};
    SOLID_RETURN_IF_ERROR(ResolveIndex(v, token, data_.positions.size(), "vertex", corner.v));
    if (!t.empty()) SOLID_RETURN_IF_ERROR(ResolveIndex(t, token, data_.uvs.size(), "texture coordinate", corner.vt));
    if (!n.empty()) SOLID_RETURN_IF_ERROR(ResolveIndex(n, token, data_.normals.size(), "normal", corner.vn));
    return Status::Ok();
  }

  Status ParseFace(Tokens& tokens) {
    corners_.clear();
    for (std::string_view token = tokens.NextField(); !token.empty(); token = tokens.NextField()) {
      if (corners_.size() >= options_.max_polygon_corners) {
        return LimitExceededError(fmt::format("{}: face has more than max_polygon_corners ({}) corners", Where(token),
                                              options_.max_polygon_corners));
      }
      SOLID_RETURN_IF_ERROR(ParseCorner(token, corners_.emplace_back()));
    }
    const size_t n = corners_.size();
    if (n < 3) {
      ++data_.counts.short_faces_dropped;
      return Status::Ok();
    }
    if (triangle_count_ + (n - 2) > options_.max_faces) {
      return LimitExceededError(fmt::format("{}:{}:1: more than max_faces ({}) triangles", name_, lines_.line_number(),
                                            options_.max_faces));
    }
    triangle_count_ += n - 2;
    const auto line = static_cast<uint32_t>(std::min<uint64_t>(lines_.line_number(), UINT32_MAX));
    std::vector<ObjTriangle>& out = CurrentBlock().triangles;
    if (n == 3) {
      out.push_back({{corners_[0], corners_[1], corners_[2]}, line});
      return Status::Ok();
    }
    ++data_.counts.polygons_triangulated;
    corner_positions_.clear();
    for (const ObjCorner& c : corners_) corner_positions_.push_back(data_.positions[static_cast<size_t>(c.v)]);
    polygon_triangles_.clear();
    switch (triangulator_.Run(corner_positions_, polygon_triangles_)) {
      case PolygonTriangulator::Outcome::kConvexFan:
        break;
      case PolygonTriangulator::Outcome::kEarClipped:
        ++data_.counts.concave_polygons;
        break;
      case PolygonTriangulator::Outcome::kConcaveFallbackFan:
        ++data_.counts.concave_polygons;
        ++data_.counts.triangulation_fallbacks;
        break;
      case PolygonTriangulator::Outcome::kDegenerateFan:
        ++data_.counts.triangulation_fallbacks;
        break;
    }
    for (size_t i = 0; i + 2 < polygon_triangles_.size(); i += 3) {
      out.push_back({{corners_[polygon_triangles_[i]], corners_[polygon_triangles_[i + 1]],
                      corners_[polygon_triangles_[i + 2]]},
                     line});
    }
    return Status::Ok();
  }

  // `l` and `p` are not geometry we render, so their indices are neither parsed nor checked.
  Status CountLineOrPoint(uint64_t& total, uint64_t ObjFaceBlock::*per_block) {
    ++total;
    ++(CurrentBlock().*per_block);
    return Status::Ok();
  }

  Status SetState(std::string& field, std::string_view value) {
    if (field != value) {
      field.assign(value);
      state_changed_ = true;
    }
    return Status::Ok();
  }

  Status SetGroup(Tokens& tokens) {
    scratch_.clear();
    for (std::string_view name = tokens.Next(); !name.empty(); name = tokens.Next()) {
      if (!scratch_.empty()) scratch_ += ' ';
      scratch_ += name;
    }
    return SetState(group_, scratch_);
  }

  Status AddMtllibs(Tokens& tokens) {
    const std::string_view rest = tokens.Rest();
    bool any_mtl = false;
    Tokens probe(rest);
    for (std::string_view t = probe.Next(); !t.empty(); t = probe.Next()) any_mtl |= EndsWithIgnoreCase(t, ".mtl");
    Tokens names(rest);
    const char* name_start = nullptr;
    for (std::string_view t = names.Next(); !t.empty(); t = names.Next()) {
      if (!name_start) name_start = t.data();
      if (!any_mtl || EndsWithIgnoreCase(t, ".mtl")) {
        data_.mtllibs.emplace_back(name_start, static_cast<size_t>(t.data() + t.size() - name_start));
        name_start = nullptr;
      }
    }
    if (name_start) data_.mtllibs.emplace_back(name_start, static_cast<size_t>(rest.data() + rest.size() - name_start));
    return Status::Ok();
  }

  // Blocks are opened lazily, on the first face/line/point after a state change, so that
  // `g` followed by `usemtl` does not leave an empty block; returning to the state of the
  // last block continues it.
  ObjFaceBlock& CurrentBlock() {
    if (state_changed_) {
      state_changed_ = false;
      if (data_.blocks.empty() || data_.blocks.back().object != object_ || data_.blocks.back().group != group_ ||
          data_.blocks.back().material != material_) {
        ObjFaceBlock& block = data_.blocks.emplace_back();
        block.object = object_;
        block.group = group_;
        block.material = material_;
      }
    }
    return data_.blocks.back();
  }

  std::span<const uint8_t> bytes_;
  std::string_view name_;
  const ObjReadOptions& options_;
  LineReader lines_;
  ObjData data_;
  std::string object_, group_, material_;
  bool state_changed_ = true;
  uint64_t triangle_count_ = 0;
  std::vector<ObjCorner> corners_;
  std::vector<std::array<double, 3>> corner_positions_;
  std::vector<uint32_t> polygon_triangles_;
  PolygonTriangulator triangulator_;
  std::string scratch_;
};

// Texture map options and how many arguments each takes (docs: MTL spec, "Texture map
// statements"); arguments beyond the minimum are taken only while they are numbers.
struct MapOption {
  std::string_view flag;
  int min_args, max_args;
};
constexpr MapOption kMapOptions[] = {
    {"-blendu", 1, 1}, {"-blendv", 1, 1}, {"-bm", 1, 1},     {"-boost", 1, 1}, {"-cc", 1, 1},
    {"-clamp", 1, 1},  {"-imfchan", 1, 1}, {"-mm", 1, 2},    {"-o", 1, 3},     {"-s", 1, 3},
    {"-t", 1, 3},      {"-texres", 1, 1},  {"-type", 1, 1},
};

// The path after the options, blanks inside kept; empty when only options were given.
std::string_view MapPath(std::string_view rest) {
  Tokens tokens(rest);
  while (true) {
    const char* before = tokens.position();
    const std::string_view token = tokens.Next();
    if (token.empty()) return {};
    const MapOption* option = nullptr;
    for (const MapOption& o : kMapOptions) {
      if (EqualsIgnoreCase(token, o.flag)) option = &o;
    }
    if (!option) return TrimBlanks({before, static_cast<size_t>(rest.data() + rest.size() - before)});
    for (int i = 0; i < option->max_args; ++i) {
      const char* arg_start = tokens.position();
      const std::string_view arg = tokens.Next();
      double unused = 0;
      if (arg.empty()) return {};
      if (i >= option->min_args && ParseDouble(arg, unused) != NumberError::kNone) {
        tokens = Tokens({arg_start, static_cast<size_t>(rest.data() + rest.size() - arg_start)});
        break;
      }
    }
  }
}

class MtlParser {
 public:
  MtlParser(std::span<const uint8_t> bytes, std::string_view name, const ObjReadOptions& options)
      : bytes_(bytes), name_(name), options_(options), lines_(bytes, name, options.max_line_length, false) {}

  Result<MtlData> Run() {
    SOLID_RETURN_IF_ERROR(CheckInput(bytes_, name_, options_));
    while (lines_.Next()) SOLID_RETURN_IF_ERROR(ParseRecord(lines_.line()));
    SOLID_RETURN_IF_ERROR(lines_.status());
    return std::move(data_);
  }

 private:
  Status ParseRecord(std::string_view line) {
    Tokens tokens(line);
    const std::string_view keyword = tokens.Next();
    if (keyword.empty() || keyword.front() == '#') return Status::Ok();
    if (EqualsIgnoreCase(keyword, "newmtl")) return StartMaterial(tokens.Rest());
    if (!current_) {
      ++data_.unknown_records;
      return Status::Ok();
    }
    if (EqualsIgnoreCase(keyword, "Kd")) return ParseKd(tokens);
    if (EqualsIgnoreCase(keyword, "d")) {
      std::string_view token = tokens.Next();
      if (EqualsIgnoreCase(token, "-halo")) token = tokens.Next();
      SOLID_RETURN_IF_ERROR(ParseNumber(token, tokens, current_->d));
      has_d_ = true;
      return Status::Ok();
    }
    if (EqualsIgnoreCase(keyword, "Tr")) {
      double transparency = 0;
      SOLID_RETURN_IF_ERROR(ParseNumber(tokens.Next(), tokens, transparency));
      if (!has_d_) current_->d = 1.0 - transparency;
      return Status::Ok();
    }
    if (EqualsIgnoreCase(keyword, "map_Kd")) return SetMap(tokens, current_->map_kd);
    if (EqualsIgnoreCase(keyword, "map_d")) return SetMap(tokens, current_->map_d);
    ++data_.unknown_records;
    return Status::Ok();
  }

  Status StartMaterial(std::string_view material_name) {
    has_d_ = false;
    if (!names_.emplace(material_name).second) {
      ++data_.duplicate_names;
      discarded_ = MtlMaterial{};
      current_ = &discarded_;
      return Status::Ok();
    }
    MtlMaterial& material = data_.materials.emplace_back();
    material.name = material_name;
    material.line = static_cast<uint32_t>(std::min<uint64_t>(lines_.line_number(), UINT32_MAX));
    current_ = &material;
    return Status::Ok();
  }

  Status ParseNumber(std::string_view token, const Tokens& tokens, double& value) const {
    if (token.empty()) {
      return ParseError(fmt::format("{}: missing number", lines_.Where(tokens.position())));
    }
    switch (ParseDouble(token, value)) {
      case NumberError::kNone:
        return Status::Ok();
      case NumberError::kMalformed:
        return ParseError(fmt::format("{}: malformed number {}", lines_.Where(token.data()), Quote(token)));
      case NumberError::kOutOfRange:
        return ParseError(fmt::format("{}: number {} is out of double range", lines_.Where(token.data()), Quote(token)));
      case NumberError::kNonFinite:
        return ParseError(fmt::format("{}: non-finite number {}", lines_.Where(token.data()), Quote(token)));
    }
    return Status::Ok();
  }

  // "Kd r g b" or "Kd r" (grey); the spectral and CIEXYZ forms are counted as unknown.
  Status ParseKd(Tokens& tokens) {
    const std::string_view first = tokens.Next();
    if (EqualsIgnoreCase(first, "spectral") || EqualsIgnoreCase(first, "xyz")) {
      ++data_.unknown_records;
      return Status::Ok();
    }
    std::array<double, 3> kd{};
    SOLID_RETURN_IF_ERROR(ParseNumber(first, tokens, kd[0]));
    const std::string_view second = tokens.Next();
    if (second.empty()) {
      current_->kd = {kd[0], kd[0], kd[0]};
      return Status::Ok();
    }
    SOLID_RETURN_IF_ERROR(ParseNumber(second, tokens, kd[1]));
    SOLID_RETURN_IF_ERROR(ParseNumber(tokens.Next(), tokens, kd[2]));
    current_->kd = kd;
    return Status::Ok();
  }

  Status SetMap(Tokens& tokens, std::optional<std::string>& map) {
    const std::string_view path = MapPath(tokens.Rest());
    if (path.empty()) {
      ++data_.unknown_records;
    } else {
      map.emplace(path);
    }
    return Status::Ok();
  }

  std::span<const uint8_t> bytes_;
  std::string_view name_;
  const ObjReadOptions& options_;
  LineReader lines_;
  MtlData data_;
  std::unordered_set<std::string> names_;
  MtlMaterial* current_ = nullptr;
  MtlMaterial discarded_;  // receives the keys of a repeated newmtl
  bool has_d_ = false;
};

}  // namespace

Result<ObjData> ReadObj(std::span<const uint8_t> bytes, std::string_view name, const ObjReadOptions& options) {
  return ObjParser(bytes, name, options).Run();
}

Result<MtlData> ReadMtl(std::span<const uint8_t> bytes, std::string_view name, const ObjReadOptions& options) {
  return MtlParser(bytes, name, options).Run();
}

}  // namespace solid::convert
