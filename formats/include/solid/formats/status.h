// Recoverable errors as values (after Draco's Status/StatusOr).
//
// Library code never throws across its public API: every fallible entry point
// returns a Status or a Result<T>. The message of a Status names where the
// problem is (file:line, shard/table/row/field, parameter) so that a user can
// find it without a debugger. Broken invariants of our own are SOLID_CHECKs.
#pragma once

#include <cstdio>
#include <cstdlib>
#include <string>
#include <string_view>
#include <utility>
#include <variant>

namespace solid {

enum class StatusCode {
  kOk = 0,
  kInvalidArgument,     // a caller-supplied option or parameter is wrong
  kIoError,             // the operating system refused a read, write, rename, sync...
  kParseError,          // text or binary input does not follow its format
  kCorrupt,             // input parsed but fails a checksum or consistency check
  kLimitExceeded,       // input is larger than a documented limit
  kUnsupportedVersion,  // a file written by a newer or foreign format version
  kNotFound,            // a file, row or key that must exist does not
  kAlreadyExists,       // refusing to overwrite something that exists
  kInternal,            // a third-party library failed in a way we cannot attribute
  kCancelled,           // the caller asked the call to stop (solid/formats/cancel.h)
};

// Stable lower-case name of a code, e.g. "io_error"; used in messages and JSON output.
std::string_view StatusCodeName(StatusCode code);

class [[nodiscard]] Status {
 public:
  Status() = default;
  Status(StatusCode code, std::string message) : code_(code), message_(std::move(message)) {}
  // kInvalidArgument for one field of a library call's options struct: the message starts
  // with "<option>: ", and option() keeps the field's name, so that a front end can name
  // its own spelling of it (the CLI's flag) without parsing the message. A field that is
  // well formed but names what is not there (a Table-1 row, an earlier export) keeps the
  // code of that, e.g. kNotFound.
  static Status ForOption(std::string_view option, std::string_view message,
                          StatusCode code = StatusCode::kInvalidArgument);

  static Status Ok() { return Status(); }

  bool ok() const { return code_ == StatusCode::kOk; }
  StatusCode code() const { return code_; }
  const std::string& message() const { return message_; }
  // The options-struct field this status is about (ForOption), else empty.
  const std::string& option() const { return option_; }

  // Prefixes the message with a location, e.g. "shards/shard-000001.sqlite: " + message.
  Status WithContext(std::string_view where) const&;
  Status WithContext(std::string_view where) &&;

  // "io_error: shards/x.sqlite: disk full"
  std::string ToString() const;

 private:
  StatusCode code_ = StatusCode::kOk;
  std::string message_;
  std::string option_;
};

inline Status InvalidArgumentError(std::string m) { return {StatusCode::kInvalidArgument, std::move(m)}; }
inline Status IoError(std::string m) { return {StatusCode::kIoError, std::move(m)}; }
inline Status ParseError(std::string m) { return {StatusCode::kParseError, std::move(m)}; }
inline Status CorruptError(std::string m) { return {StatusCode::kCorrupt, std::move(m)}; }
inline Status LimitExceededError(std::string m) { return {StatusCode::kLimitExceeded, std::move(m)}; }
inline Status UnsupportedVersionError(std::string m) { return {StatusCode::kUnsupportedVersion, std::move(m)}; }
inline Status NotFoundError(std::string m) { return {StatusCode::kNotFound, std::move(m)}; }
inline Status AlreadyExistsError(std::string m) { return {StatusCode::kAlreadyExists, std::move(m)}; }
inline Status InternalError(std::string m) { return {StatusCode::kInternal, std::move(m)}; }
inline Status CancelledError(std::string m) { return {StatusCode::kCancelled, std::move(m)}; }
inline Status OptionError(std::string_view option, std::string_view m,
                          StatusCode code = StatusCode::kInvalidArgument) {
  return Status::ForOption(option, m, code);
}

// Either a value or a non-OK Status. C++20 has no std::expected.
template <typename T>
class [[nodiscard]] Result {
 public:
  Result(T value) : data_(std::move(value)) {}  // NOLINT(google-explicit-constructor)
  Result(Status status) : data_(std::move(status)) {  // NOLINT(google-explicit-constructor)
    if (std::get<Status>(data_).ok()) {
      std::fprintf(stderr, "solid: Result constructed from an OK Status\n");
      std::abort();
    }
  }

  bool ok() const { return std::holds_alternative<T>(data_); }
  const Status& status() const {
    static const Status kOkStatus;
    return ok() ? kOkStatus : std::get<Status>(data_);
  }
  T& value() & { return std::get<T>(data_); }
  const T& value() const& { return std::get<T>(data_); }
  T&& value() && { return std::get<T>(std::move(data_)); }
  T* operator->() { return &value(); }
  const T* operator->() const { return &value(); }
  T& operator*() & { return value(); }
  const T& operator*() const& { return value(); }

 private:
  std::variant<T, Status> data_;
};

namespace internal {
[[noreturn]] void CheckFailed(const char* file, int line, const char* expr, const std::string& detail);
}  // namespace internal

}  // namespace solid

#define SOLID_STATUS_CONCAT_INNER(a, b) a##b
#define SOLID_STATUS_CONCAT(a, b) SOLID_STATUS_CONCAT_INNER(a, b)

#define SOLID_RETURN_IF_ERROR(expr)          \
  do {                                       \
    ::solid::Status solid_status_ = (expr);  \
    if (!solid_status_.ok()) return solid_status_; \
  } while (0)

#define SOLID_ASSIGN_OR_RETURN_IMPL(tmp, lhs, expr) \
  auto tmp = (expr);                                \
  if (!tmp.ok()) return tmp.status();               \
  lhs = std::move(tmp).value()

#define SOLID_ASSIGN_OR_RETURN(lhs, expr) \
  SOLID_ASSIGN_OR_RETURN_IMPL(SOLID_STATUS_CONCAT(solid_result_, __LINE__), lhs, expr)

// Invariants of our own code (never for input validation): abort with the location.
#define SOLID_CHECK(cond)                                                   \
  do {                                                                      \
    if (!(cond)) ::solid::internal::CheckFailed(__FILE__, __LINE__, #cond, {}); \
  } while (0)
