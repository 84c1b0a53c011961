#pragma once
// SIGINT/SIGTERM as a stop request for the long-running commands (run, record): the handler only sets a
// lock-free atomic (async-signal-safe); the command's main loop polls stop_requested().
namespace rutd {

void install_stop_handlers();
bool stop_requested() noexcept;

}  // namespace rutd
