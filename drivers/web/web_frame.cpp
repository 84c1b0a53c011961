#include "web/web_frame.hpp"

namespace rutd {

void web_frame_copy(const PublishedFrame& f, WebFrame& to) {
  to.seq = f.seq;
  to.t_ns = f.t_ns;
  to.skew_ns = f.skew_ns;
  to.measurement = f.measurement;
  to.health = f.health;
  to.motion = f.motion;
  to.position = f.position;
  to.times = f.times;
  to.has_images = f.left_raw != nullptr && f.right_raw != nullptr;
  if (to.has_images) {
    f.left_raw->copyTo(to.left_raw);  // reuses the buffer when size and type fit
    f.right_raw->copyTo(to.right_raw);
  }
  to.has_strips = f.left_strip != nullptr && f.right_strip != nullptr && f.section != nullptr && f.geometry != nullptr;
  if (!to.has_strips) return;
  f.left_strip->copyTo(to.left_strip);
  f.right_strip->copyTo(to.right_strip);
  to.strip_row0 = f.strip_row0;
  to.measured_row0 = f.measured_row0;
  to.measured_rows = f.measured_rows;
  to.section.x0_mm = f.section->x0_mm;
  to.section.dx_mm = f.section->dx_mm;
  to.section.z_mm.assign(f.section->z_mm.begin(), f.section->z_mm.end());  // keeps the capacity
  to.section.count.assign(f.section->count.begin(), f.section->count.end());
  to.geometry = *f.geometry;
}

}  // namespace rutd
