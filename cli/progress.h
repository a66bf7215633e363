// A progress line on stderr: redrawn in place with rate and ETA on a terminal,
// plain periodic lines otherwise (logs of batch jobs).
#pragma once

#include <chrono>
#include <string>

#include "solid/formats/progress.h"

namespace solid::cli {

class ProgressLine {
 public:
  explicit ProgressLine(std::string label, std::string unit);
  ~ProgressLine();  // ends the line
  ProgressCallback Callback();
  void Update(int64_t done, int64_t total);

 private:
  std::string label_, unit_;
  bool tty_;
  std::chrono::steady_clock::time_point start_, last_;
  bool drawn_ = false;
};

}  // namespace solid::cli
