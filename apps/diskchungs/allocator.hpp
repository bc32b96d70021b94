// The heap allocator's settings for the CLI (why: allocator.cpp).
#pragma once
#include <string>

namespace chungs::app {

// Call first in main(), before any thread starts: caps glibc's arenas unless the environment does.
void limit_allocator_arenas();
// e.g. "glibc malloc, 2 arenas", for `diskchungs info`.
std::string allocator_description();

}  // namespace chungs::app
