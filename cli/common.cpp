#include <fmt/format.h>

#include "commands.h"
#include "exit_codes.h"

namespace solid::cli {

int Fail(const Status& status) {
  fmt::print(stderr, "solid: {}\n", status.message());
  return ExitCodeFor(status);
}

}  // namespace solid::cli
