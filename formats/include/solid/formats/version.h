// The version and the commit of this build of solid: what `solid --version` prints and what
// every manifest's generator records.
#pragma once

#include <string_view>

namespace solid {

// The project's version (CMake's PROJECT_VERSION).
std::string_view Version();
// The commit the build's sources were at, abbreviated to 12 digits, with "-dirty" when they
// had uncommitted changes, or "unknown" outside a git checkout.
std::string_view BuildCommit();

}  // namespace solid
