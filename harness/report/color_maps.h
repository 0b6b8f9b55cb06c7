#pragma once
// Colour ramps for false-colour images: piecewise-linear in sRGB between a few stops of published maps.

#include <array>
#include <cstdint>

namespace sahbench {

using Rgb8 = std::array<uint8_t, 3>;

/// Sequential map for counts (0 = least, 1 = most): five stops of matplotlib's viridis (van der Walt
/// and Smith 2015), which stays ordered in lightness and readable for colour-blind viewers.
Rgb8 sequential_color(float t);

/// Diverging map for signed differences (-1 = most negative, 0 = none, +1 = most positive): the
/// cool-warm map of Moreland 2009, "Diverging Color Maps for Scientific Visualization" (blue, grey,
/// red), so that zero is neutral and the sign reads at a glance.
Rgb8 diverging_color(float t);

}  // namespace sahbench
