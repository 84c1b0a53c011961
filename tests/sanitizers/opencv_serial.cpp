// Preloaded (LD_PRELOAD) into the ThreadSanitizer test run by scripts/test-sanitizers: makes OpenCV run
// cv::parallel_for_ on the calling thread. Debian's OpenCV hands parallel loops to oneTBB, which is not
// built with ThreadSanitizer, so the hand-off and join are invisible to it: every loop body's access from
// a TBB worker is reported as a race, and suppressing them costs a symbolized report per pixel, which
// stalls the program. OPENCV_FOR_THREADS_NUM does not reach the TBB backend; cv::setNumThreads(0) does.
// rutd's own threads are untouched and stay checked.
#include <opencv2/core.hpp>

namespace {
struct OpenCvSerial {
  OpenCvSerial() { cv::setNumThreads(0); }
} opencv_serial;
}  // namespace
