// Shared helpers of the E3D shaders (included with GL_GOOGLE_include_directive).
#ifndef E3D_COMMON_GLSL
#define E3D_COMMON_GLSL
#include "ips/e3d_shaders/interface.h"

// Path cost of disparities beyond the search range (padding up to a whole number of words per lane):
// larger than any real path cost, so it never wins a minimum.
const uint E3D_BIG = 0x3FFFu;

// 8-bit images are stored four pixels to a 32-bit word, row-major without padding.
#define E3D_PIXEL(buf, idx) ((buf[(idx) >> 2] >> (((idx)&3) << 3)) & 0xFFu)

#endif
