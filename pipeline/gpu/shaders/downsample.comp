#version 450
// The band estimate's coarse images (gl_GlobalInvocationID.z: 0 left, 1 right): each coarse pixel the
// mean of a block of `scale` columns by `row_factor` rows of the strip, rounded half up in integers, as
// downsample_reference (rectify.hpp). One invocation per word of four coarse pixels; written packed into
// the census buffers as scratch, from which the host's command buffer copies them over the strips.
layout(local_size_x = 64) in;
layout(std430, binding = 0) readonly buffer Left { uint left_px[]; };
layout(std430, binding = 1) readonly buffer Right { uint right_px[]; };
layout(std430, binding = 2) writeonly buffer CoarseL { uint coarse_l[]; };
layout(std430, binding = 3) writeonly buffer CoarseR { uint coarse_r[]; };
layout(push_constant) uniform Params {
  int width, height, words_per_row, coarse_width, coarse_height, coarse_words_per_row, scale, row_factor;
} pc;
#include "common.glsl"

void main() {
  const int word = int(gl_GlobalInvocationID.x), y = int(gl_GlobalInvocationID.y);
  const bool right = gl_GlobalInvocationID.z == 1u;
  if (word >= pc.coarse_words_per_row || y >= pc.coarse_height) return;
  const uint area = uint(pc.scale * pc.row_factor);
  uint packed = 0u;
  for (int k = 0; k < 4; ++k) {
    const int x = word * 4 + k;
    if (x >= pc.coarse_width) break;
    uint sum = 0u;
    for (int dy = 0; dy < pc.row_factor; ++dy) {
      for (int dx = 0; dx < pc.scale; ++dx) {
        const int sx = x * pc.scale + dx, sy = y * pc.row_factor + dy;
        const int i = sy * pc.words_per_row + (sx >> 2);
        sum += pixel_at(right ? right_px[i] : left_px[i], sx);
      }
    }
    packed |= ((sum + area / 2u) / area) << uint(8 * k);
  }
  if (right) coarse_r[y * pc.coarse_words_per_row + word] = packed; else coarse_l[y * pc.coarse_words_per_row + word] = packed;
}
