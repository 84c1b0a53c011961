#include "fd_write.hpp"

#include <unistd.h>

#include <algorithm>
#include <cerrno>

namespace rutd {

bool fd_write_all(int fd, const void* data, std::size_t size, IoFaults* faults, IoPoint point) {
  const auto* bytes = static_cast<const char*>(data);
  std::size_t done = 0;
  while (done < size) {
    std::size_t ask = size - done;
    if (const int fault = faults != nullptr ? faults->check(point) : 0) {
      if (fault > 0) {
        errno = fault;
        return false;
      }
      if (fault == io_fault::kShort) ask = std::max<std::size_t>(1, ask / 2);
    }
    const ssize_t n = ::write(fd, bytes + done, ask);
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) return false;
    if (n == 0) {
      errno = ENOSPC;
      return false;
    }
    done += static_cast<std::size_t>(n);
  }
  return true;
}

}  // namespace rutd
