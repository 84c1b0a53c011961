// A program that links rutd_pipeline and nothing else of rutd: its link line is what check_layering.sh
// inspects. It measures one black frame so that the linker really pulls the pipeline's objects in.
#include <opencv2/core.hpp>

#include "measurement/measurer.hpp"

int main() {
  rutd::StereoCalibration calibration;
  calibration.image_size = {320, 240};
  calibration.M1 = calibration.M2 = cv::Matx33d(300, 0, 160, 0, 300, 120, 0, 0, 1);
  calibration.D1 = calibration.D2 = cv::Mat::zeros(1, 5, CV_64F);
  calibration.R = cv::Matx33d::eye();
  calibration.T = cv::Vec3d(-60, 0, 0);
  rutd::StereoMeasurer measurer(calibration, rutd::MeasurerConfig{});
  const cv::Mat black = cv::Mat::zeros(calibration.image_size, CV_8UC1);
  const rutd::RutMeasurement m = measurer.measure(black, black);
  return m.status == rutd::RutStatus::Ok ? 1 : 0;  // a black pair has nothing to measure
}
