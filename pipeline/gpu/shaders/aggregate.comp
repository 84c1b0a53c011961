#version 450
// All SGM path directions in one dispatch: workgroup (line, direction) walks one line of the image in
// direction kDirections[direction] (as sgm_reference.cpp), its 64 invocations own the disparities (pairs
// q = invocation + 64 j: disparities 2q, 2q+1), and it adds the path cost L to the sum volume, which the
// host zeroed. Matching cost: Hamming distance of the census words of left x and right
// x - (min_disparity + d); 64 where that leaves the right image.
//   L(p, d) = C(p, d) + min(L(p-r, d), L(p-r, d-1) + P1, L(p-r, d+1) + P1, min_k L(p-r, k) + P2) - min_k L(p-r, k)
// L <= 64 + P2 and the host keeps 8 (64 + P2) < 65536, so two 16-bit sums share one word without carries
// and one atomicAdd adds both; the directions run concurrently, and integer addition in any order gives
// the same sums. Works for any subgroup size: the minimum over disparities is a subgroup minimum, then
// one value per subgroup through shared memory. The next pixel's census words are loaded before the
// barrier that ends a step, so their latency overlaps the synchronisation.
#extension GL_KHR_shader_subgroup_basic : require
#extension GL_KHR_shader_subgroup_arithmetic : require
layout(local_size_x = 64) in;
layout(std430, binding = 0) readonly buffer CensusL { uvec2 census_l[]; };
layout(std430, binding = 1) readonly buffer CensusR { uvec2 census_r[]; };
layout(std430, binding = 2) buffer Sum { uint sum[]; };  // [y][x][pair], two 16-bit sums per word
layout(push_constant) uniform Params { int width, height, min_disparity, num_disparities, p1, p2; } pc;

const uint kBig = 0xFFFFu;  // beyond any L; the sentinels at d = -1 and d = num_disparities
const int kMaxDisparities = 512;
const int kPairsPerInvocation = kMaxDisparities / 128;
const ivec2 kDirections[8] = ivec2[8](ivec2(1, 0), ivec2(-1, 0), ivec2(0, 1), ivec2(0, -1), ivec2(1, 1), ivec2(-1, 1),
                                      ivec2(1, -1), ivec2(-1, -1));
shared uint path[2][kMaxDisparities + 2];  // L of the previous and current pixel, index d + 1
shared uint subgroup_min[2][64];

void main() {
  const int W = pc.width, H = pc.height;
  const int dx = kDirections[gl_WorkGroupID.y].x, dy = kDirections[gl_WorkGroupID.y].y;
  const int line = int(gl_WorkGroupID.x);
  if (line >= (dy == 0 ? H : dx == 0 ? W : W + H - 1)) return;  // the whole workgroup: no barrier skipped
  // Start of the line: the pixels whose predecessor (x - dx, y - dy) lies outside the image.
  int x, y;
  if (dy == 0) {
    x = dx > 0 ? 0 : W - 1; y = line;
  } else if (line < W) {
    x = line; y = dy > 0 ? 0 : H - 1;
  } else {  // diagonals starting on the left or right column, below (above) the first row
    x = dx > 0 ? 0 : W - 1;
    y = dy > 0 ? 1 + (line - W) : H - 2 - (line - W);
  }
  const int t = int(gl_LocalInvocationID.x);
  const int pairs = pc.num_disparities / 2;
  for (int i = t; i < kMaxDisparities + 2; i += 64) { path[0][i] = kBig; path[1][i] = kBig; }

  // Census words of the current pixel: left, and right at x - min_disparity - d for the owned disparities.
  uvec2 cl = census_l[y * W + x];
  uvec2 cr[kPairsPerInvocation][2];
  for (int j = 0; j < kPairsPerInvocation; ++j)
    for (int e = 0; e < 2; ++e) {
      const int xr = x - pc.min_disparity - 2 * (t + 64 * j) - e;
      cr[j][e] = xr >= 0 && t + 64 * j < pairs ? census_r[y * W + xr] : uvec2(0u);
    }
  barrier();

  uint prev_min = 0u;
  for (int step = 0; x >= 0 && x < W && y >= 0 && y < H; ++step) {
    const int cur = step & 1, prv = cur ^ 1;
    uint local_min = kBig;
    for (int j = 0; j < kPairsPerInvocation; ++j) {
      const int q = t + 64 * j;
      if (q >= pairs) break;
      uint l2[2];
      for (int e = 0; e < 2; ++e) {
        const int d = 2 * q + e;
        const uint c = x - pc.min_disparity - d >= 0 ? uint(bitCount(cl.x ^ cr[j][e].x) + bitCount(cl.y ^ cr[j][e].y)) : 64u;
        uint l = c;
        if (step > 0) {
          const uint near = min(path[prv][d], path[prv][d + 2]) + uint(pc.p1);
          l = c + min(min(path[prv][d + 1], near), prev_min + uint(pc.p2)) - prev_min;
        }
        path[cur][d + 1] = l;
        local_min = min(local_min, l);
        l2[e] = l;
      }
      atomicAdd(sum[(y * W + x) * pairs + q], l2[0] | (l2[1] << 16));
    }
    x += dx;
    y += dy;
    if (x >= 0 && x < W && y >= 0 && y < H) {  // prefetch the next pixel's census words
      cl = census_l[y * W + x];
      for (int j = 0; j < kPairsPerInvocation; ++j)
        for (int e = 0; e < 2; ++e) {
          const int xr = x - pc.min_disparity - 2 * (t + 64 * j) - e;
          cr[j][e] = xr >= 0 && t + 64 * j < pairs ? census_r[y * W + xr] : uvec2(0u);
        }
    }
    const uint m = subgroupMin(local_min);
    if (subgroupElect()) subgroup_min[cur][gl_SubgroupID] = m;
    barrier();  // path[cur] and subgroup_min[cur] complete; the next step writes the other halves
    prev_min = kBig;
    for (uint s = 0u; s < gl_NumSubgroups; ++s) prev_min = min(prev_min, subgroup_min[cur][s]);
  }
}
