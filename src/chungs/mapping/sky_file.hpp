// The sky texture's file in a map folder (sky.bin, committed with each checkpoint like the keyframe
// list): magic, texel counts, the sky frame, colours, Adam moments and step counts, then a
// checksum of everything before it. The reader checks the declared size against the file's length
// before it allocates anything.
#pragma once
#include <filesystem>

#include "chungs/render/sky.hpp"

namespace chungs {

void write_sky_file(const std::filesystem::path& file, const SkyTexture& sky, bool durable);
// Throws Error naming the file: wrong magic, sizes out of range or not matching its length, a bad
// checksum, non-finite values.
SkyTexture read_sky_file(const std::filesystem::path& file);

}  // namespace chungs
