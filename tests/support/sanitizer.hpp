#pragma once
// Whether this build runs under AddressSanitizer (STENCIL_GIS_SANITIZE=ON). A stress test whose
// size is not what it checks (the same code runs at any size, and the release build runs it at
// full size) takes a smaller size there, where every memory access costs several times more:
// the sanitizer looks for what goes wrong in the code, not at a scale.
#include <cstddef>

namespace gis::test {

#if defined(__SANITIZE_ADDRESS__)
inline constexpr bool kSanitized = true;
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
inline constexpr bool kSanitized = true;
#else
inline constexpr bool kSanitized = false;
#endif
#else
inline constexpr bool kSanitized = false;
#endif

/// The vertices of the stress tests' one big polygon: a million, a fifth of it under a sanitizer.
inline constexpr int kStressPolygonVertices = kSanitized ? 200000 : 1000000;

}  // namespace gis::test
