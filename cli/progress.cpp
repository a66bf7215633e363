#include "progress.h"

#include <unistd.h>

#include <cstdio>

#include <fmt/format.h>

namespace solid::cli {

ProgressLine::ProgressLine(std::string label, std::string unit)
    : label_(std::move(label)), unit_(std::move(unit)), tty_(isatty(STDERR_FILENO) != 0),
      start_(std::chrono::steady_clock::now()), last_(start_) {}

ProgressLine::~ProgressLine() {
  if (drawn_ && tty_) std::fputc('\n', stderr);
}

ProgressCallback ProgressLine::Callback() {
  return [this](int64_t done, int64_t total) { Update(done, total); };
}

void ProgressLine::Update(int64_t done, int64_t total) {
  auto now = std::chrono::steady_clock::now();
  // Redraw at most 10 times a second on a terminal; log every 10 s otherwise.
  auto interval = tty_ ? std::chrono::milliseconds(100) : std::chrono::milliseconds(10000);
  if (now - last_ < interval && done < total) return;
  last_ = now;
  double seconds = std::chrono::duration<double>(now - start_).count();
  double rate = seconds > 0 ? static_cast<double>(done) / seconds : 0;
  std::string eta = rate > 0 && total >= done ? fmt::format("{:.0f}s", static_cast<double>(total - done) / rate) : "?";
  std::string text = fmt::format("{}: {}/{} {} ({:.1f} {}/s, ETA {})", label_, done, total, unit_, rate, unit_, eta);
  if (tty_) {
    fmt::print(stderr, "\r\033[K{}", text);
  } else {
    fmt::print(stderr, "{}\n", text);
  }
  std::fflush(stderr);
  drawn_ = true;
}

}  // namespace solid::cli
