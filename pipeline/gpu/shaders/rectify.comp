#version 450
// Rectification of both raw images (gl_GlobalInvocationID.z: 0 left, 1 right) into the matcher's packed
// strips, one invocation per word of four strip pixels (no two invocations write one word). Each pixel
// samples its raw image at its map position with the cubic B-spline kernel; the arithmetic is that of
// rectify_reference.cpp, operation for operation (`precise`: no fused multiply-adds), rounded half to even.
layout(local_size_x = 64) in;
layout(std430, binding = 0) readonly buffer RawL { uint raw_l[]; };
layout(std430, binding = 1) readonly buffer RawR { uint raw_r[]; };
layout(std430, binding = 2) readonly buffer MapL { vec2 map_l[]; };
layout(std430, binding = 3) readonly buffer MapR { vec2 map_r[]; };
layout(std430, binding = 4) writeonly buffer Left { uint left_px[]; };
layout(std430, binding = 5) writeonly buffer Right { uint right_px[]; };
// raw_row0: the first raw row uploaded (rectify_rows()); every row the taps read is uploaded.
layout(push_constant) uniform Params {
  int width, height, words_per_row, raw_width, raw_height, raw_words_per_row, raw_row0;
} pc;
#include "common.glsl"

float raw_at(bool right, int x, int y) {
  const int i = (y - pc.raw_row0) * pc.raw_words_per_row + (x >> 2);
  return float(pixel_at(right ? raw_r[i] : raw_l[i], x));
}

void weights(float t, out precise vec4 w) {
  precise const float t2 = t * t;
  precise const float t3 = t2 * t;
  precise const float u = 1.0 - t;
  const float kSixth = 1.0 / 6.0;
  w.x = u * u * u * kSixth;
  w.y = (3.0 * t3 - 6.0 * t2 + 4.0) * kSixth;
  w.z = (-3.0 * t3 + 3.0 * t2 + 3.0 * t + 1.0) * kSixth;
  w.w = t3 * kSixth;
}

uint sample_at(bool right, vec2 position) {
  const int max_x = pc.raw_width - 1, max_y = pc.raw_height - 1;
  precise const float x = clamp(position.x, 0.0, float(max_x));
  precise const float y = clamp(position.y, 0.0, float(max_y));
  const int x0 = int(x), y0 = int(y);
  precise vec4 wx, wy;
  weights(x - float(x0), wx);
  weights(y - float(y0), wy);
  ivec4 xs;
  for (int k = 0; k < 4; ++k) xs[k] = clamp(x0 - 1 + k, 0, max_x);
  precise float sum = 0.0;
  for (int j = 0; j < 4; ++j) {
    const int yj = clamp(y0 - 1 + j, 0, max_y);
    precise const float row = wx.x * raw_at(right, xs.x, yj) + wx.y * raw_at(right, xs.y, yj) +
                              wx.z * raw_at(right, xs.z, yj) + wx.w * raw_at(right, xs.w, yj);
    sum = sum + wy[j] * row;
  }
  return uint(clamp(roundEven(sum), 0.0, 255.0));
}

void main() {
  const int word = int(gl_GlobalInvocationID.x), y = int(gl_GlobalInvocationID.y);
  const bool right = gl_GlobalInvocationID.z == 1u;
  if (word >= pc.words_per_row || y >= pc.height) return;
  uint packed = 0u;  // padding pixels past the width stay 0, as the host packs them
  for (int k = 0; k < 4; ++k) {
    const int x = word * 4 + k;
    if (x >= pc.width) break;
    const int i = y * pc.width + x;
    packed |= sample_at(right, right ? map_r[i] : map_l[i]) << uint(8 * k);
  }
  if (right) right_px[y * pc.words_per_row + word] = packed; else left_px[y * pc.words_per_row + word] = packed;
}
