#pragma once
// How the C library's allocator gives memory back, for programs that draw frames.

namespace gis {

/// Keeps freed memory at the top of the heap for the next frame instead of returning it to the
/// system at once. A software OpenGL driver (Mesa's llvmpipe) allocates its binned scene in the
/// drawing thread and frees it after each frame; glibc then returns the top of the heap to the
/// system (its trim threshold starts at 128 KiB) and the next frame faults every page of it back
/// in. On Olinda's oblique views that was two thirds of a frame with overlays (239 → 61–63 ms;
/// docs/measurements.md). This raises the trim threshold to 256 MiB and fixes the threshold
/// above which blocks get their own mapping at 32 MiB (glibc's own ceiling for it, which
/// setting the first would otherwise freeze at 128 KiB). Peak memory does not change: memory
/// kept is memory already used, and is used again. A no-op where the C library is not glibc.
/// Our programs call it first thing; a client that draws with the library may do the same.
void keepFreedHeapForFrames();

}  // namespace gis
