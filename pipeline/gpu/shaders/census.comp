#version 450
// 9x7 census transform of both images (gl_GlobalInvocationID.z: 0 left, 1 right). Bit k (row-major over
// the window, centre skipped, 62 bits: 0..31 in .x, 32..61 in .y) is set when that neighbour is darker than
// the centre; neighbours outside the image are clamped to the border.
layout(local_size_x = 16, local_size_y = 8) in;
layout(std430, binding = 0) readonly buffer Left { uint left_px[]; };
layout(std430, binding = 1) readonly buffer Right { uint right_px[]; };
layout(std430, binding = 2) writeonly buffer CensusL { uvec2 census_l[]; };
layout(std430, binding = 3) writeonly buffer CensusR { uvec2 census_r[]; };
layout(push_constant) uniform Params { int width, height, words_per_row; } pc;
#include "common.glsl"

uint load(bool right, int x, int y) {
  x = clamp(x, 0, pc.width - 1);
  y = clamp(y, 0, pc.height - 1);
  const int i = y * pc.words_per_row + (x >> 2);
  return pixel_at(right ? right_px[i] : left_px[i], x);
}

void main() {
  const int x = int(gl_GlobalInvocationID.x), y = int(gl_GlobalInvocationID.y);
  const bool right = gl_GlobalInvocationID.z == 1u;
  if (x >= pc.width || y >= pc.height) return;
  const uint c = load(right, x, y);
  uvec2 bits = uvec2(0u);
  int k = 0;
  for (int dy = -3; dy <= 3; ++dy) {
    for (int dx = -4; dx <= 4; ++dx) {
      if (dx == 0 && dy == 0) continue;
      const uint b = load(right, x + dx, y + dy) < c ? 1u : 0u;
      if (k < 32) bits.x |= b << uint(k); else bits.y |= b << uint(k - 32);
      ++k;
    }
  }
  if (right) census_r[y * pc.width + x] = bits; else census_l[y * pc.width + x] = bits;
}
