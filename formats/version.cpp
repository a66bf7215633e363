#include "solid/formats/version.h"

namespace solid {

std::string_view Version() { return SOLID_VERSION; }

}  // namespace solid
