#version 450
// All SGM path directions in one dispatch: workgroup (line, direction) walks one line of the image in
// direction kDirections[direction] (as sgm_reference.cpp), or kLines lines with LINES (below). A line's
// invocations own consecutive blocks of kWords words of four disparities: invocation t has
// d = 4 (kWords t + k) + e, k < kWords, e < 4. They read the matching costs C of a word from cost.comp's volume and store the four path costs L
// as one word of four bytes in that direction's own volume, path_cost[direction][y][x][word];
// winner-takes-all (wta.comp) adds the directions. No atomics and no zeroing: every word is written once.
//   L(p, d) = C(p, d) + min(L(p-r, d), L(p-r, d-1) + P1, L(p-r, d+1) + P1, min_k L(p-r, k) + P2) - min_k L(p-r, k)
// L <= 64 + P2, and the host keeps P2 <= 191 (kMaxP2), so L fits a byte.
//
// Disparities past the band cost 255 (cost.comp), so their L stays at least 255 while the band's minimum
// is at most 64 (the L of the last step's best d is its cost): they never become the minimum and their
// L + P1 never undercuts min L + P2, so the band's L are the reference's without a test per disparity.
// Their bytes are not used downstream.
//
// Each step depends on the last, so the walk is bound by the latency of a step. An invocation keeps its
// own L in registers; only the L at the edges of its block and the minimum cross invocations. When the
// workgroup is one subgroup (kThreads is the device's subgroup size) they cross by shuffles and a
// subgroup minimum: no barrier, no shared memory. Where the device runs it as several subgroups (a
// driver free to pick a smaller size), they cross through shared memory with one barrier a step: the
// same arithmetic, slower. The costs of the next kRing steps are loaded while the current kRing steps run
// (the loops over the ring and an invocation's disparities are unrolled, so both live in registers); the
// addresses advance by a constant per step.
//
// Built twice (pipeline/gpu/CMakeLists.txt): with HALF defined, the step runs in packed half floats, two
// disparities an operation (f16vec2; the device's shaderFloat16). Every value is then an integer below
// 2,048, which half floats hold exactly: each L is kept as 1024 + L, whose bits are 0x6400 | L, so a cost
// byte becomes a half by an OR and an L byte is the half's low byte.
#extension GL_KHR_shader_subgroup_basic : require
#extension GL_KHR_shader_subgroup_arithmetic : require
#extension GL_KHR_shader_subgroup_shuffle_relative : require
#extension GL_EXT_control_flow_attributes : require
#ifdef HALF
#extension GL_EXT_shader_explicit_arithmetic_types_float16 : require
const bool kHalf = true;
#else
const bool kHalf = false;
#endif
// Set when the pipeline is made: the workgroup size (the device's subgroup size for the fast path), kWords
// = the band's words of four disparities / kLanes rounded up, and kLanes, the invocations that walk one
// line: the whole workgroup, or with LINES defined (aggregate_lines, built from this file as HALF is)
// fewer: kThreads / kLanes lines a workgroup, kLanes a power of two dividing the device's subgroup size,
// so that a line's invocations lie in one subgroup. With fewer lanes each invocation owns more
// disparities: the step's fixed work (the minimum across invocations, the edge shuffles, the addressing)
// is shared by more of them, and the minimum is a butterfly of log2(kLanes) shuffles within the line's
// lanes, with no barrier and no shared memory. Two builds rather than a specialization constant: the
// H100's compiler made the one-line walk 35% slower with the other's code present, though unreachable.
layout(local_size_x_id = 0) in;
layout(constant_id = 0) const int kThreads = 32;
layout(constant_id = 1) const int kWords = 1;
#ifdef LINES
#extension GL_KHR_shader_subgroup_shuffle : require
layout(constant_id = 2) const int kLanes = 8;
const int kLines = kThreads / kLanes;  // lines a workgroup walks
#endif
layout(std430, binding = 0) readonly buffer Cost { uint cost[]; };  // cost.comp's, [y][x][word]
// One buffer per direction (each within the device's storage-buffer range), [y][x][word], 4 bytes a word;
// words per pixel: num_disparities / 16 rounded up, times 4.
layout(std430, binding = 1) writeonly buffer PathCost { uint w[]; } path_cost[8];
// segment, run_in: SgmConfig::segment (0: off) and segment_run_in; workgroup z is the segment of a row.
layout(push_constant) uniform Params { int width, height, p1, p2, words, segment, run_in; } pc;

const uint kBig = 0xFFFFu;  // beyond any L: past the ends of the band
const int kRing = 8;  // steps whose costs are loaded ahead (registers: 2 kRing kWords)
const int kOwn = 4 * kWords;  // disparities per invocation
const ivec2 kDirections[8] = ivec2[8](ivec2(1, 0), ivec2(-1, 0), ivec2(0, 1), ivec2(0, -1), ivec2(1, 1), ivec2(-1, 1),
                                      ivec2(1, -1), ivec2(-1, -1));
// The shared-memory exchange, by step parity: each invocation's first and last L, each subgroup's minimum.
#ifndef LINES
shared uint edge_first[2][kThreads], edge_last[2][kThreads], subgroup_min[2][kThreads];
#endif

#ifdef HALF
// 1024 + each byte of a word as halves, bytes 0, 1 and bytes 2, 3.
f16vec2 biased_low(uint w) { return unpackFloat2x16(0x64006400u | (w & 0xFFu) | ((w & 0xFF00u) << 8)); }
f16vec2 biased_high(uint w) { return unpackFloat2x16(0x64006400u | ((w >> 16) & 0xFFu) | ((w >> 8) & 0xFF0000u)); }
// The low bytes of two pairs of biased halves, as a word of four L.
uint bytes_of(f16vec2 a, f16vec2 b) {
  const uint u = packFloat2x16(a), v = packFloat2x16(b);
  return (u & 0xFFu) | ((u >> 8) & 0xFF00u) | ((v & 0xFFu) << 16) | ((v << 8) & 0xFF000000u);
}
#endif

void main() {
  const int W = pc.width, H = pc.height;
  const uint dir = gl_WorkGroupID.y;
  const int dx = kDirections[dir].x, dy = kDirections[dir].y;
  const int t = int(gl_LocalInvocationID.x);
  const int lines = dy == 0 ? H : dx == 0 ? W : W + H - 1;
#ifdef LINES
  const int lane = t % kLanes;  // among the invocations of this line
  int line = int(gl_WorkGroupID.x) * kLines + t / kLanes;
  // A line past the last walks nothing (its invocations stay for their subgroup's shuffles).
  const bool live = line < lines;
  line = min(line, lines - 1);
#else
  const int lane = t;
  const int line = int(gl_WorkGroupID.x);
  if (line >= lines) return;  // the whole workgroup: no barrier skipped
#endif
  // Start of the line: the pixels whose predecessor (x - dx, y - dy) lies outside the image.
  int x0, y0;
  if (dy == 0) {
    x0 = dx > 0 ? 0 : W - 1; y0 = line;
  } else if (line < W) {
    x0 = line; y0 = dy > 0 ? 0 : H - 1;
  } else {  // diagonals starting on the left or right column, below (above) the first row
    x0 = dx > 0 ? 0 : W - 1;
    y0 = dy > 0 ? 1 + (line - W) : H - 2 - (line - W);
  }
  // Rows in segments: segment z keeps walk steps [z S, (z + 1) S), walked from max(0, z S - run_in).
  const int seg = int(gl_WorkGroupID.z);
  int keep_from = 0, seg_end = 1 << 30;
  if (dy == 0 && pc.segment > 0) {
    if (seg * pc.segment >= W) return;
    const int begin = max(0, seg * pc.segment - pc.run_in);
    seg_end = min((seg + 1) * pc.segment, W) - begin;
    keep_from = seg * pc.segment - begin;
    x0 += begin * dx;
  } else if (seg > 0) {
    return;  // other directions, and unsegmented rows, have one segment
  }
  const int along_x = dx == 0 ? 1 << 30 : dx > 0 ? W - x0 : x0 + 1;
  const int along_y = dy == 0 ? 1 << 30 : dy > 0 ? H - y0 : y0 + 1;
  // Until the line leaves the image or its segment. LINES: the subgroup's lines step together for their
  // shuffles, as long as the longest of them, each storing only its own steps.
#ifdef LINES
  const int steps = live ? min(min(along_x, along_y), seg_end) : 0;
  const int group_steps = int(subgroupMax(uint(steps)));
#else
  const int steps = min(min(along_x, along_y), seg_end);
  const int group_steps = steps;
  const bool one_subgroup = gl_NumSubgroups == 1u;
#endif
  const int first_word = kWords * lane;
  // This invocation's words at the line's first pixel, and the step between pixels, in words.
  const int stride = (dy * W + dx) * pc.words;
  int at = (y0 * W + x0) * pc.words + first_word;

  // Words past the volume's (whole blocks of 16 disparities) read as disparities past the band.
  uint ring[kRing][kWords], next[kRing][kWords];
  [[unroll]] for (int s = 0; s < kRing; ++s)
    [[unroll]] for (int k = 0; k < kWords; ++k)
      ring[s][k] = s < steps && first_word + k < pc.words ? cost[at + s * stride + k] : 0xFFFFFFFFu;

  uint prev[kOwn];
  [[unroll]] for (int i = 0; i < kOwn; ++i) prev[i] = kBig;
#ifdef HALF
  f16vec2 prev_h[kOwn / 2];
  const float16_t big_h = float16_t(2047.0);  // 1024 + 1023: beyond any biased L
  [[unroll]] for (int i = 0; i < kOwn / 2; ++i) prev_h[i] = f16vec2(big_h);
  const f16vec2 p1_h = f16vec2(float16_t(pc.p1)), p2_h = f16vec2(float16_t(pc.p2));
#endif
  uint below = kBig, above = kBig;  // L(p-r) at this block's first d - 1 and last d + 1
  uint prev_min = 0u;               // kHalf: biased
  for (int block = 0; block * kRing < group_steps; ++block) {
    [[unroll]] for (int s = 0; s < kRing; ++s)  // the next block's costs, in flight during this block
      [[unroll]] for (int k = 0; k < kWords; ++k)
        next[s][k] = (block + 1) * kRing + s < steps && first_word + k < pc.words
                         ? cost[at + ((block + 1) * kRing + s) * stride + k]
                         : 0xFFFFFFFFu;
    [[unroll]] for (int s = 0; s < kRing; ++s) {
      const int step = block * kRing + s;
      if (step >= group_steps) break;  // uniform: the whole workgroup (subgroup) leaves together
#ifdef LINES
      const bool store = step >= keep_from && step < steps;
#else
      const bool store = step >= keep_from;
#endif
      const int here = at + step * stride;
      uint local_min, first, last;
#ifdef HALF
      {
        f16vec2 cur[kOwn / 2];
        f16vec2 m2 = f16vec2(big_h);
        const f16vec2 floor_h = f16vec2(float16_t(prev_min)) + p2_h;  // min L + P2
        const float16_t below_h = float16_t(below), above_h = float16_t(above);
        [[unroll]] for (int j = 0; j < kOwn / 2; ++j) {
          const uint word = ring[s][j / 2];
          const f16vec2 c = (j & 1) == 0 ? biased_low(word) : biased_high(word);
          f16vec2 l = c;
          if (step > 0) {
            const f16vec2 lo = f16vec2(j == 0 ? below_h : prev_h[j == 0 ? 0 : j - 1].y, prev_h[j].x);
            const f16vec2 hi = f16vec2(prev_h[j].y, j == kOwn / 2 - 1 ? above_h : prev_h[j == kOwn / 2 - 1 ? j : j + 1].x);
            l = c + (min(min(prev_h[j], min(lo, hi) + p1_h), floor_h) - f16vec2(float16_t(prev_min)));
          }
          cur[j] = l;
          m2 = min(m2, l);
        }
        [[unroll]] for (int k = 0; k < kWords; ++k)
          if (first_word + k < pc.words && store)
            path_cost[dir].w[here + k] = bytes_of(cur[2 * k], cur[2 * k + 1]);
        local_min = uint(min(m2.x, m2.y));
        first = uint(cur[0].x);
        last = uint(cur[kOwn / 2 - 1].y);
        [[unroll]] for (int j = 0; j < kOwn / 2; ++j) prev_h[j] = cur[j];
      }
#else
      {
        uint cur[kOwn];
        local_min = kBig;
        [[unroll]] for (int i = 0; i < kOwn; ++i) {
          const uint c = (ring[s][i / 4] >> uint(8 * (i % 4))) & 0xFFu;
          uint l = c;
          if (step > 0) {
            const uint lo = i == 0 ? below : prev[i == 0 ? 0 : i - 1];
            const uint hi = i == kOwn - 1 ? above : prev[i == kOwn - 1 ? i : i + 1];
            l = c + min(min(prev[i], min(lo, hi) + uint(pc.p1)), prev_min + uint(pc.p2)) - prev_min;
          }
          local_min = min(local_min, l);
          cur[i] = l;
        }
        [[unroll]] for (int k = 0; k < kWords; ++k)
          if (first_word + k < pc.words && store)
            path_cost[dir].w[here + k] = (cur[4 * k] & 0xFFu) | ((cur[4 * k + 1] & 0xFFu) << 8) |
                                         ((cur[4 * k + 2] & 0xFFu) << 16) | ((cur[4 * k + 3] & 0xFFu) << 24);
        first = cur[0];
        last = cur[kOwn - 1];
        [[unroll]] for (int i = 0; i < kOwn; ++i) prev[i] = cur[i];
      }
#endif
      // Past either end of the band: kBig (biased or not, beyond any L).
      const uint big = kHalf ? 2047u : kBig;
#ifdef LINES
      // Shuffles that cross into the neighbouring line are replaced at the line's first and last lane.
      below = subgroupShuffleUp(last, 1u);
      above = subgroupShuffleDown(first, 1u);
      if (lane == 0) below = big;
      if (lane == kLanes - 1) above = big;
      uint m = local_min;
      [[unroll]] for (int o = 1; o < kLanes; o <<= 1) m = min(m, subgroupShuffleXor(m, uint(o)));
      prev_min = m;
#else
      if (one_subgroup) {
        below = subgroupShuffleUp(last, 1u);
        above = subgroupShuffleDown(first, 1u);
        if (t == 0) below = big;
        if (t == kThreads - 1) above = big;
        prev_min = subgroupMin(local_min);
      } else {
        const int par = step & 1;  // two copies: the next step's writes need no second barrier
        edge_first[par][t] = first;
        edge_last[par][t] = last;
        const uint m = subgroupMin(local_min);
        if (subgroupElect()) subgroup_min[par][gl_SubgroupID] = m;
        barrier();
        below = t > 0 ? edge_last[par][t - 1] : big;
        above = t < kThreads - 1 ? edge_first[par][t + 1] : big;
        prev_min = kBig;
        for (uint g = 0u; g < gl_NumSubgroups; ++g) prev_min = min(prev_min, subgroup_min[par][g]);
      }
#endif
    }
    [[unroll]] for (int r = 0; r < kRing; ++r)
      [[unroll]] for (int k = 0; k < kWords; ++k) ring[r][k] = next[r][k];
  }
}
