#pragma once
// Ray files (text): one ray per line, "ox oy oz dx dy dz [tmin tmax]", numbers separated by spaces, tabs
// or commas; tmin defaults to 0 and tmax to infinity ("inf" is accepted). Blank lines and lines starting
// with '#' are ignored. `sahbench trace` reads them (cli/trace_command.h).

#include <cstddef>
#include <filesystem>
#include <vector>

#include "core/ray.h"

namespace sahbench {

/// Reads a ray file: one ray per line, `ox oy oz dx dy dz [tmin tmax]`, separated by spaces, tabs or commas;
/// `#` starts a comment, and a first line of column names is a header. A malformed line, an empty field,
/// a number outside float range, NaN, an infinite origin or direction, a negative or infinite tmin, a zero
/// direction, a directory or a file without rays is an Error naming the file, line and token. With
/// `lines`, each ray's line number (from 1) is stored there, so that a later check can name it too.
std::vector<Ray> read_rays(const std::filesystem::path& path, std::vector<std::size_t>* lines = nullptr);

}  // namespace sahbench
