#version 450
// Winner-takes-all on the summed path costs, as a row walker. Left view: the lowest sum (lowest d on
// ties), rejected (-1) when another disparity more than 1 away has sum * (100 - uniqueness) < best * 100,
// or when the pixel is closer than min_disparity + num_disparities - 1 to the left edge (part of the band
// has no match); sub-pixel by a parabola through the sums at d-1, d, d+1, in 1/64 px, integer arithmetic:
//   d64 = (min_disparity + d) 64 + trunc(((S[d-1] - S[d+1]) 64 + den) / (2 den)), den = max(S[d-1] + S[d+1] - 2 S[d], 1)
// Right view (for the left-right check): the d minimising S(xr + min_disparity + d, d), lowest d on ties,
// written as the key S * 512 + d (0xFFFFFFFF: no disparity), which lr_median.comp reads.
//
// Workgroup (segment, row): kThreads invocations walk the row's pixels x left to right, invocation t
// owning disparities d = 4 kWords t + i, i < 4 kWords. At each pixel it adds its words of every
// direction's byte costs (aggregate.comp) into 16-bit sums in registers (at most 8 * 255 = 2,040, so two
// sums share a word without carries), and forms keys S * 512 + d (20 bits), so that the minimum key is the
// lowest sum and then the lowest d, as the reference's scan. The best key is a group minimum; the
// uniqueness test needs only the minimum over d more than 1 from the best (no d beats a threshold unless
// that minimum does), a second group minimum; S[d-1] and S[d+1] come from the invocations that own them.
//
// The right view is a rolling minimum carried along the disparities: acc_d(x) = min(acc_{d-1}(x - 1),
// key(x, d)) holds, for right pixel xr = x - min_disparity - d, the minimum over d' <= d of its candidates
// (x - d + d', d'). An invocation updates its own d from the top down and takes acc_{d-1} of its first d
// from the previous invocation (a shuffle); acc at d = num_disparities - 1 is complete and written at
// every step, and at the row's end every acc_d is complete (its other candidates lie past the edge).
// Whole rows (this build, segment 0): no atomics and no buffer to fill, every pixel of both outputs is
// written once.
//
// Segments (built with SEGMENTED, wta_segmented, for push constant segment > 0): workgroup x walks columns
// [x0, x0 + segment) and no others, so that a row's segments share no work. A right pixel's candidates
// then span up to 1 + num_disparities / segment segments, each of which gives the minimum over its own
// candidates: the segment that holds the last candidate where it writes acc_{num_disparities - 1}, the
// others from their acc_d at their last column (every acc_d of a segment's last column is written). Each
// goes into right_key by atomicMin, over the frame's fill of 0xFFFFFFFF (frame.cpp). Two builds: with the
// segments' code present the whole-row walk of a workgroup of several subgroups (the shared-memory path)
// gave wrong disparities on an H100, as segments in such a workgroup still do (the host never runs them:
// vulkan_sgm.cpp), while the whole-row build and every configuration on lavapipe are right.
//
// Where the workgroup is one subgroup (kThreads the device's subgroup size) the group operations are
// subgroup operations, with no barrier; where a driver splits it into several subgroups they go through
// shared memory with a barrier each: the same arithmetic, slower.
#extension GL_KHR_shader_subgroup_basic : require
#extension GL_KHR_shader_subgroup_arithmetic : require
#extension GL_KHR_shader_subgroup_shuffle : require
#extension GL_KHR_shader_subgroup_shuffle_relative : require
#extension GL_EXT_control_flow_attributes : require
// Set when the pipeline is made: the workgroup size, the words of four disparities per invocation
// (num_disparities / 4 / kThreads rounded up), num_disparities and the number of directions.
layout(local_size_x_id = 0) in;
layout(constant_id = 0) const int kThreads = 32;
layout(constant_id = 1) const int kWords = 1;
layout(constant_id = 2) const int kD = 128;
layout(constant_id = 3) const int kPaths = 8;
// aggregate.comp's, [y][x][word], `words` words per pixel.
layout(std430, binding = 0) readonly buffer PathCost { uint w[]; } path_cost[8];
layout(std430, binding = 1) writeonly buffer DispL { int disp_l[]; };
#ifdef SEGMENTED
layout(std430, binding = 2) buffer RightKey { uint right_key[]; };  // atomicMin
#else
layout(std430, binding = 2) writeonly buffer RightKey { uint right_key[]; };
#endif
layout(push_constant) uniform Params { int width, height, min_disparity, uniqueness, words, segment; } pc;

const uint kNone = 0xFFFFFFFFu;
const int kOwn = 4 * kWords;          // disparities per invocation
const int kUsedWords = (kD + 3) / 4;  // words holding a disparity of the band
// Steps whose costs are loaded ahead: fewer where an invocation owns many words (small subgroups).
const int kRing = kWords >= 4 ? 1 : 4 / kWords;
const int kEmitLane = (kD - 1) / kOwn;   // the invocation that owns d = num_disparities - 1
const int kEmitIndex = (kD - 1) % kOwn;  // and where among its disparities

// The shared-memory exchange of a workgroup of several subgroups, two copies used in turn: a copy is
// written again only after the next operation's barrier, which every invocation reaches after reading it.
shared uint exchange[2][kThreads];
bool one_subgroup;
int lane;  // the invocation's index: its subgroup invocation where the workgroup is one subgroup
int turn = 0;

uint group_min(uint v) {
  const uint m = subgroupMin(v);
  if (one_subgroup) return m;
  if (subgroupElect()) exchange[turn][gl_SubgroupID] = m;
  barrier();
  uint r = kNone;
  for (uint g = 0u; g < gl_NumSubgroups; ++g) r = min(r, exchange[turn][g]);
  turn ^= 1;
  return r;
}

// v of invocation `from` (uniform).
uint value_of(uint v, int from) {
  if (one_subgroup) return subgroupShuffle(v, uint(from));
  exchange[turn][lane] = v;
  barrier();
  const uint r = exchange[turn][from];
  turn ^= 1;
  return r;
}

// v of the previous invocation; `none` for the first.
uint from_previous(uint v, uint none) {
  uint r;
  if (one_subgroup) {
    r = subgroupShuffleUp(v, 1u);
  } else {
    exchange[turn][lane] = v;
    barrier();
    r = lane > 0 ? exchange[turn][lane - 1] : none;
    turn ^= 1;
  }
  return lane > 0 ? r : none;
}

void main() {
  one_subgroup = gl_NumSubgroups == 1u;
  lane = one_subgroup ? int(gl_SubgroupInvocationID) : int(gl_LocalInvocationID.x);
  const int W = pc.width, y = int(gl_WorkGroupID.y), dmin = pc.min_disparity;
  int x_begin = 0, x_end = W;
  if (pc.segment > 0) {
    x_begin = int(gl_WorkGroupID.x) * pc.segment;
    x_end = min(W, x_begin + pc.segment);
  }
  if (x_begin >= W) return;  // the whole workgroup: no barrier skipped
#ifdef SEGMENTED
  const int start = x_begin;
#else
  const int start = max(0, x_begin - (kD - 1));  // x_begin is 0 (segment 0): the run-in is never taken
#endif
  const int first_word = kWords * lane, first_d = 4 * first_word;
  const int row = y * W;

  uint acc[kOwn];  // the right view's rolling minima of this invocation's d
  [[unroll]] for (int i = 0; i < kOwn; ++i) acc[i] = kNone;

  // Costs of kRing steps in registers, the next kRing steps' loads in flight meanwhile.
  uint ring[kRing][kPaths][kWords], next[kRing][kPaths][kWords];
  int at = (row + start) * pc.words + first_word;  // index of this invocation's first word at pixel x
  [[unroll]] for (int s = 0; s < kRing; ++s)
    [[unroll]] for (int k = 0; k < kPaths; ++k)
      [[unroll]] for (int w = 0; w < kWords; ++w)
        ring[s][k][w] = start + s < x_end && first_word + w < kUsedWords ? path_cost[k].w[at + s * pc.words + w] : 0u;

  for (int x0 = start; x0 < x_end; x0 += kRing) {
    [[unroll]] for (int s = 0; s < kRing; ++s)
      [[unroll]] for (int k = 0; k < kPaths; ++k)
        [[unroll]] for (int w = 0; w < kWords; ++w)
          next[s][k][w] = x0 + kRing + s < x_end && first_word + w < kUsedWords
                              ? path_cost[k].w[at + (kRing + s) * pc.words + w]
                              : 0u;
    [[unroll]] for (int s = 0; s < kRing; ++s) {
      const int x = x0 + s;
      if (x >= x_end) break;  // uniform: the whole workgroup leaves together
      // Sums: bytes 0 and 2 of every word added as 16-bit halves, and bytes 1 and 3.
      uint key[kOwn];
      [[unroll]] for (int w = 0; w < kWords; ++w) {
        uint even = 0u, odd = 0u;
        [[unroll]] for (int k = 0; k < kPaths; ++k) {
          even += ring[s][k][w] & 0x00FF00FFu;
          odd += (ring[s][k][w] >> 8) & 0x00FF00FFu;
        }
        const uint sums[4] = uint[4](even & 0xFFFFu, odd & 0xFFFFu, even >> 16, odd >> 16);
        [[unroll]] for (int e = 0; e < 4; ++e) {
          const int d = first_d + 4 * w + e;
          key[4 * w + e] = d < kD ? (sums[e] << 9) | uint(d) : kNone;
        }
      }
      // Right view: acc_d = min(acc_{d-1} of the last step, key_d), from the top down.
      const uint carry = from_previous(acc[kOwn - 1], kNone);
      [[unroll]] for (int i = kOwn - 1; i > 0; --i) acc[i] = min(acc[i - 1], key[i]);
      acc[0] = min(carry, key[0]);
#ifndef SEGMENTED
      if (x < x_begin) continue;
#endif
      if (lane == kEmitLane) {
        const int xr = x - dmin - (kD - 1);
#ifdef SEGMENTED
        if (xr >= 0) atomicMin(right_key[row + xr], acc[kEmitIndex]);
#else
        if (xr >= 0) right_key[row + xr] = acc[kEmitIndex];
#endif
      }
      int out_l = -1;
      if (x >= dmin + kD - 1) {  // uniform
        uint local = kNone;
        [[unroll]] for (int i = 0; i < kOwn; ++i) local = min(local, key[i]);
        const uint best = group_min(local);
        const int bd = int(best & 511u);
        const uint bs = best >> 9;
        // The minimum beyond the best's neighbours, and the neighbours' sums (S[d-1] high, S[d+1] low).
        uint beyond = kNone, near = 0u;
        [[unroll]] for (int i = 0; i < kOwn; ++i) {
          const int d = first_d + i;
          if (abs(d - bd) > 1) beyond = min(beyond, key[i]);
          if (d == bd - 1) near |= (key[i] >> 9) << 16;
          if (d == bd + 1) near |= key[i] >> 9;
        }
        const uint second = group_min(beyond);
        if (second == kNone || (second >> 9) * uint(100 - pc.uniqueness) >= bs * 100u) {
          out_l = (dmin + bd) * 64;
          if (bd > 0 && bd < kD - 1) {
            const int a = int(value_of(near, (bd - 1) / kOwn) >> 16);
            const int b = int(value_of(near, (bd + 1) / kOwn) & 0xFFFFu);
            const int den = max(a + b - 2 * int(bs), 1);
            const int num = (a - b) * 64 + den;
            out_l += num >= 0 ? num / (2 * den) : -((-num) / (2 * den));
          }
        }
      }
      if (lane == 0) disp_l[row + x] = out_l;
    }
    [[unroll]] for (int s = 0; s < kRing; ++s)
      [[unroll]] for (int k = 0; k < kPaths; ++k)
        [[unroll]] for (int w = 0; w < kWords; ++w) ring[s][k][w] = next[s][k][w];
    at += kRing * pc.words;
  }

  // A segment's last column: acc_d holds the segment's share of xr = x_end - 1 - dmin - d (d =
  // num_disparities - 1 was written above).
#ifdef SEGMENTED
  [[unroll]] for (int i = 0; i < kOwn; ++i) {
    const int d = first_d + i, xr = x_end - 1 - dmin - d;
    if (d < kD - 1 && xr >= 0) atomicMin(right_key[row + xr], acc[i]);
  }
  // Right pixels past W - 1 - dmin keep the fill: no candidate.
#else
  // The row's end: every acc_d is complete for xr = W - 1 - dmin - d (d = num_disparities - 1 was
  // written above); right pixels past W - 1 - dmin have no candidate.
  if (x_end == W) {
    [[unroll]] for (int i = 0; i < kOwn; ++i) {
      const int d = first_d + i, xr = W - 1 - dmin - d;
      if (d < kD - 1 && xr >= 0) right_key[row + xr] = acc[i];
    }
    for (int j = lane; j < dmin; j += kThreads) {
      const int xr = W - dmin + j;
      if (xr >= 0) right_key[row + xr] = kNone;
    }
  }
#endif
}
