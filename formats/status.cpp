#include "solid/formats/status.h"

namespace solid {

std::string_view StatusCodeName(StatusCode code) {
  switch (code) {
    case StatusCode::kOk: return "ok";
    case StatusCode::kInvalidArgument: return "invalid_argument";
    case StatusCode::kIoError: return "io_error";
    case StatusCode::kParseError: return "parse_error";
    case StatusCode::kCorrupt: return "corrupt";
    case StatusCode::kLimitExceeded: return "limit_exceeded";
    case StatusCode::kUnsupportedVersion: return "unsupported_version";
    case StatusCode::kNotFound: return "not_found";
    case StatusCode::kAlreadyExists: return "already_exists";
    case StatusCode::kInternal: return "internal";
    case StatusCode::kCancelled: return "cancelled";
  }
  return "unknown";
}

Status Status::ForOption(std::string_view option, std::string_view message, StatusCode code) {
  Status status(code, std::string(option) + ": " + std::string(message));
  status.option_ = option;
  return status;
}

Status Status::WithContext(std::string_view where) const& {
  if (ok()) return *this;
  Status status(code_, std::string(where) + ": " + message_);
  status.option_ = option_;
  return status;
}

Status Status::WithContext(std::string_view where) && {
  if (ok()) return std::move(*this);
  message_.insert(0, std::string(where) + ": ");
  return std::move(*this);
}

std::string Status::ToString() const {
  if (ok()) return "ok";
  return std::string(StatusCodeName(code_)) + ": " + message_;
}

namespace internal {
void CheckFailed(const char* file, int line, const char* expr, const std::string& detail) {
  std::fprintf(stderr, "%s:%d: SOLID_CHECK failed: %s %s\n", file, line, expr, detail.c_str());
  std::abort();
}
}  // namespace internal

}  // namespace solid
