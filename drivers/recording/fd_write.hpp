#pragma once
// write(2) until every byte is out, shared by the recording writer, the calibration file and the
// measurement CSV sink. Private to drivers/recording.
#include <cstddef>

#include "core/io_faults.hpp"

namespace rutd {

// Writes all `size` bytes of `data` to `fd`, retrying after EINTR and after short writes. Returns false
// with errno set on the first failed write (a write of 0 bytes reads as ENOSPC); bytes written before it
// stay written. `faults` (tests only, core/io_faults.hpp) is asked before every write() at `point`: an
// errno fails that write as the kernel would; io_fault::kShort writes half of what is asked (at least a
// byte), as a write interrupted or near a quota may.
bool fd_write_all(int fd, const void* data, std::size_t size, IoFaults* faults = nullptr,
                  IoPoint point = IoPoint::RecordWrite);

}  // namespace rutd
