#pragma once
// The scene matrix: synthetic scenes as hard as the field, on which rutd's trust in a depth is judged
// (`rutd bench --scenes`, daemon/bench_scenes.cpp). Its groups:
//   spoiled  water in the rut (turbid, clear, covered by floating debris, glinting, rippled by wind or
//            rain; 5-30 mm deep in sand, mud, snow and grass; roll 0-5 degrees) and every fault on the
//            lenses (mud, snow, drops, spray, dust) on the left, the right and both lenses, and night
//            (auto exposure out of exposure and gain): every frame must be measured within 1 mm of the
//            soil's truth or refused with one of `expect`;
//   clean    clean ruts across textures (low-texture snow included), rigs, rut shapes, exposures, manual
//            gain and auto exposure in dim light, right cameras a few percent brighter or darker than
//            the left: every frame should be measured within 1 mm (a refusal is a false alarm);
//   steep    clean ruts with steep walls (51-61 degrees, 55-80 mm deep) in snow, mud and grass, whose
//            walls DIC loses most: as clean, every frame should be measured within 1 mm, counted apart;
//   tread    clean ruts with tread marks in their bottom (whose truth excludes the grooves);
//   skew     free-running cameras: the right exposure a few milliseconds after the left at speed;
//   entry    a rut deepening into a pool (turbid, covered by debris, or clear): the first pairs dry, the
//            next ones wet, the water deepening from under a millimetre on the first; like spoiled, every
//            frame within 1 mm or refused (with Water where wet). The case where what a dry frame saw
//            a moment ago is most like what the first wet one sees.
// Every rut fits the rig's view with its piles and some ground beside them.
// Each scene is a `rutd synth` command line, so any one can be rendered and replayed by hand. Parameters
// are drawn once from fixed ranges by a fixed-seed generator (varied, not chosen to pass), so the list is
// the same on every machine and every run.
#include <string>
#include <vector>

namespace rutd {

struct MatrixScene {
  std::string name;   // unique, e.g. "water-clear-mud-07"
  std::string group;  // "spoiled", "clean", "steep", "tread", "skew" or "entry"
  std::string kind;   // e.g. "water-clear", "lens-mud-left", "clean-auto-dim"
  // What rightly refuses it: RutConditions signals, or a status with no condition bit (UNSYNCHRONISED),
  // config/rutd.dbc names.
  std::vector<std::string> expect;
  std::string synth;  // rutd synth options besides the folder and --frames
};

// The default matrix: 40 water scenes and 24 more under floating debris, 15 lens faults, 4 at night, 64
// clean scenes, 16 steep ones, 6 with tread, 6 skewed pairs, 10 entries into a pool.
std::vector<MatrixScene> scene_matrix();

}  // namespace rutd
