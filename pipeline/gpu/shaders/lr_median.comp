#version 450
// Left-right check, then a 3x3 median, then pixels to float. A left disparity v (1/64 px) survives the
// check when the right view's disparity at x - round(v) is within max_diff px of round(v), round(v) =
// (v + 32) >> 6 (max_diff < 0: no check). The right view comes as wta.comp's keys: min_disparity +
// (key & 511), 0xFFFFFFFF none. The median is taken over the nine checked values with
// invalid = -1 (so invalid neighbours pull toward invalid); pixels on the image border keep their own.
// Output (push constant outputs): bit 0, px as float, NaN invalid (the DIC's start, and tests); bit 1, the
// 16-bit fixed-point disparity the host downloads (common.glsl), exact: scale is a multiple of 64.
#extension GL_EXT_shader_16bit_storage : require
layout(local_size_x = 64) in;
layout(std430, binding = 0) readonly buffer DispL { int disp_l[]; };
layout(std430, binding = 1) readonly buffer RightKey { uint right_key[]; };
layout(std430, binding = 2) writeonly buffer Out { float disparity[]; };
layout(std430, binding = 3) writeonly buffer Fixed { uint16_t fixed_disparity[]; };
layout(push_constant) uniform Params { int width, height, max_diff, median, min_disparity, outputs, base, scale; } pc;
#include "common.glsl"

int checked(int x, int y) {
  const int v = disp_l[y * pc.width + x];
  if (v < 0 || pc.max_diff < 0) return v;
  const int d = (v + 32) >> 6;
  const int xr = x - d;
  if (xr < 0) return -1;
  const uint key = right_key[y * pc.width + xr];
  return key != 0xFFFFFFFFu && abs(pc.min_disparity + int(key & 511u) - d) <= pc.max_diff ? v : -1;
}

void main() {
  const int x = int(gl_GlobalInvocationID.x), y = int(gl_GlobalInvocationID.y);
  if (x >= pc.width || y >= pc.height) return;
  int m;
  if (pc.median == 0 || x == 0 || y == 0 || x == pc.width - 1 || y == pc.height - 1) {
    m = checked(x, y);
  } else {
    int v[9];
    int n = 0;
    for (int dy = -1; dy <= 1; ++dy)
      for (int dx = -1; dx <= 1; ++dx) v[n++] = checked(x + dx, y + dy);
    for (int i = 1; i < 9; ++i) {  // insertion sort: the median of nine, exactly as the reference
      const int k = v[i];
      int j = i - 1;
      while (j >= 0 && v[j] > k) { v[j + 1] = v[j]; --j; }
      v[j + 1] = k;
    }
    m = v[4];
  }
  if ((pc.outputs & 1) != 0) disparity[y * pc.width + x] = m < 0 ? uintBitsToFloat(0x7FC00000u) : float(m) / 64.0;
  if ((pc.outputs & 2) != 0)
    fixed_disparity[y * pc.width + x] = uint16_t(m < 0 ? kInvalidDisparity : uint((m - 64 * pc.base) * (pc.scale / 64)));
}
