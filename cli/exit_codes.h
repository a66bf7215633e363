// The documented exit codes of every solid command (README.md, "Exit codes").
#pragma once

#include "solid/formats/status.h"

namespace solid::cli {

enum ExitCode : int {
  kExitOk = 0,
  kExitProblems = 1,     // the command ran, and found problems (validate) or failed items (batches)
  kExitUsage = 2,        // bad flags or arguments
  kExitBadInput = 3,     // input missing, unparsable, corrupt, over a limit or of another version
  kExitIoError = 4,      // the operating system refused a read or write
  kExitInternal = 70,    // a bug or an unexpected library failure
  kExitSigint = 130,     // stopped by SIGINT (128 + 2) before the work was done
  kExitSigterm = 143,    // stopped by SIGTERM (128 + 15) before the work was done
};

inline int ExitCodeFor(const Status& s) {
  switch (s.code()) {
    case StatusCode::kOk: return kExitOk;
    case StatusCode::kInvalidArgument: return kExitUsage;
    case StatusCode::kIoError:
    case StatusCode::kAlreadyExists: return kExitIoError;
    case StatusCode::kParseError:
    case StatusCode::kCorrupt:
    case StatusCode::kLimitExceeded:
    case StatusCode::kUnsupportedVersion:
    case StatusCode::kNotFound: return kExitBadInput;
    case StatusCode::kInternal: return kExitInternal;
    // Only the CLI's signal handler cancels; Fail() refines this to the signal received.
    case StatusCode::kCancelled: return kExitSigint;
  }
  return kExitInternal;
}

}  // namespace solid::cli
