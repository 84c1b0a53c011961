// Calibration file reading and checking: being written.
