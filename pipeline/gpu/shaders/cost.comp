#version 450
// Matching costs, four disparities to a word: invocation (x words + word, y) writes C(x, y, d) for d = 4 word + e,
// e < 4, in byte e of cost[(y width + x) words + word]: the Hamming distance of the census words of left
// x and right x - (min_disparity + d), 64 where that leaves the right image; bytes past num_disparities
// 255, which keeps their path costs out of aggregate.comp's minima.
layout(local_size_x = 64) in;
layout(std430, binding = 0) readonly buffer CensusL { uvec2 census_l[]; };
layout(std430, binding = 1) readonly buffer CensusR { uvec2 census_r[]; };
layout(std430, binding = 2) writeonly buffer Cost { uint cost[]; };
layout(push_constant) uniform Params { int width, height, min_disparity, num_disparities, words; } pc;

void main() {
  const int word = int(gl_GlobalInvocationID.x) % pc.words;
  const int x = int(gl_GlobalInvocationID.x) / pc.words, y = int(gl_GlobalInvocationID.y);
  if (x >= pc.width || y >= pc.height) return;
  const int pixel = y * pc.width + x;
  const uvec2 cl = census_l[pixel];
  uint packed = 0u;
  for (int e = 0; e < 4; ++e) {
    const int d = 4 * word + e;
    const int xr = x - pc.min_disparity - d;
    uint c = d < pc.num_disparities ? 64u : 255u;
    if (xr >= 0 && d < pc.num_disparities) {
      const uvec2 cr = census_r[pixel - (x - xr)];
      c = uint(bitCount(cl.x ^ cr.x) + bitCount(cl.y ^ cr.y));
    }
    packed |= c << uint(8 * e);
  }
  cost[pixel * pc.words + word] = packed;
}
