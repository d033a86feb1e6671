// Shared helpers of the E3D shaders (included with GL_GOOGLE_include_directive).
#ifndef E3D_COMMON_GLSL
#define E3D_COMMON_GLSL

// Disparity maps hold disparity * 16; this value marks pixels without a disparity (ips::e3d::kInvalidDisparity).
const int E3D_INVALID = -32768;
// Path cost of disparities beyond the search range (padding up to a whole number of words per lane):
// larger than any real path cost, so it never wins a minimum.
const uint E3D_BIG = 0x3FFFu;
// Largest number of buffers a path-cost volume is split into (each at most maxStorageBufferRange).
#define E3D_MAX_CHUNKS 24

// 8-bit images are stored four pixels to a 32-bit word, row-major without padding.
#define E3D_PIXEL(buf, idx) ((buf[(idx) >> 2] >> (((idx)&3) << 3)) & 0xFFu)

#endif
